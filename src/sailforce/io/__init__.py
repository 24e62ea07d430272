"""Files: atomic writes that never clobber a recording, tables read in chunks, and robot files.

- :mod:`.files`: :func:`atomic_writer`, output-path checks, numeric CSV and JSON;
- :mod:`.tables`: CSV and Parquet tables of readings, read in chunks with
  every malformed row flagged;
- :mod:`.robotfile`: the robot file (TOML) and its template.
"""
