"""Files: atomic writes that never clobber a recording, tables read in chunks, and robot files.

- :mod:`.files`: :func:`atomic_writer`, output-path checks, numeric CSV and JSON;
- :mod:`.tables`: CSV and Parquet tables of readings, read in chunks with
  every malformed row flagged;
- :mod:`.robotfile`: the robot file (TOML) and its template.
"""

from .._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "files": (
        "CSV_SUFFIXES", "PARQUET_SUFFIXES", "atomic_writer", "check_output", "check_regular_output", "check_sidecar",
        "numeric_table_writer", "write_numeric_table", "output_set", "read_numeric_csv", "sidecar_path", "table_format", "write_figure",
        "write_json",
    ),
    "robotfile": (
        "KNOWN_SECTIONS", "LINK_KEYS", "LOADCELL_KEYS", "MATERIAL_KEYS", "NAME_KEYS", "SECTION_KEYS", "SECTIONS",
        "TEMPLATE", "RobotFile", "load_arm", "load_robot_file", "robot_data", "robot_from_data", "template",
        "write_template",
    ),
    "robotkeys": (
        "PLAUSIBLE", "get_key", "plausibility_warnings", "robot_keys", "with_keys",
    ),
    "tables": (
        "CHUNK_BYTES", "MAX_ABS_VALUE", "MAX_FIELD_CHARS", "MAX_LINE_BYTES", "READING_COLUMNS", "REFERENCE_COLUMNS",
        "Chunk", "Header", "check_columns", "chunk_jobs", "csv_chunks", "csv_header", "input_size", "is_parquet",
        "parquet_schema", "parse_lines", "read_all", "read_chunks", "read_clean", "read_header", "read_line",
        "to_float",
    ),
})
