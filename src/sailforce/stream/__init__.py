"""The estimate over files of any size and over live line streams, in chunks, one output row per input row.

- :func:`stream_estimate`: a CSV or Parquet file to a CSV or Parquet file;
- :func:`estimate_lines`: a live stream of CSV lines (stdin, serial) to a byte sink;
- :class:`MotionStage`: each row's joint rates, in order, and the dynamic term to subtract.
"""

from .motion import MotionColumns, MotionRows, MotionStage, motion_columns
from .output import MOTION_OUTPUT_COLUMNS, OUTPUT_COLUMNS, csv_rows
from .pipeline import ByteSink, estimate_lines, stream_estimate, table_motion

__all__ = [
    "MOTION_OUTPUT_COLUMNS",
    "OUTPUT_COLUMNS",
    "ByteSink",
    "MotionColumns",
    "MotionRows",
    "MotionStage",
    "csv_rows",
    "estimate_lines",
    "motion_columns",
    "stream_estimate",
    "table_motion",
]
