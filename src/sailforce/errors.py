"""Exceptions raised by sailforce.

Every error is a :class:`SailError`, so callers can catch one type, and
falls in one of three families that a caller can tell apart:

- :class:`InputError` (a :class:`ValueError`): the input is wrong (a file, a
  table, a pose, a key); the message says what was expected and what arrived;
- :class:`ToolError` (a :class:`RuntimeError`): a tool sailforce drives failed
  (CalculiX, gmsh, a Dask cluster, a recording's converter);
- :class:`MissingExtraError` (an :class:`ImportError`): an optional dependency
  is not installed; the message names the extra to install.

The CLI prints every message verbatim as its one-line error, so messages are
written for people.  Every exception class of sailforce is defined here.
"""

from __future__ import annotations


class SailError(Exception):
    """Base class of every error sailforce raises."""


class InputError(SailError, ValueError):
    """Input that sailforce cannot use: the base of every error about data, files, poses and options."""


class ToolError(SailError, RuntimeError):
    """A tool that sailforce drives failed, or is missing (a solver, a mesher, a cluster)."""


class ShapeError(InputError):
    """An array argument has the wrong shape or cannot be broadcast."""


class NonFiniteInputError(InputError):
    """An array argument holds NaN or infinity where a number is required."""


class GeometryError(InputError):
    """Link lengths that cannot form the SAIL parallelogram."""


class RobotFileError(InputError):
    """A robot TOML file is missing, malformed, or describes an impossible arm."""


class UnreachablePointError(InputError):
    """An end-effector position lies outside the arm's annular workspace."""


class SingularPoseError(InputError):
    """A pose where |sin(theta1 - theta2)| is too small to invert J^T.

    There the parallelogram is (nearly) collapsed, and the end-effector force
    error grows as 1/|sin(theta1 - theta2)| (docs/errata.md, Statics).
    """


class SpecError(InputError):
    """A sweep specification that cannot be read."""


class TableError(InputError):
    """A table that cannot be read: missing, empty, ragged, a bad header or cell, missing columns, corrupt Parquet."""


class OutputPathError(InputError):
    """An output path that would overwrite an input, or that names no format sailforce writes."""


class CalibrationFileError(InputError):
    """A calibration file that is missing, corrupt, tampered with or out of range."""


class CompensationError(InputError):
    """Data that cannot determine a compensator."""


class RegressorError(InputError):
    """A table that cannot support the requested polynomial fit."""


class FilterError(InputError):
    """A filter specification that cannot be realised."""


class MotionDataError(InputError):
    """Timestamps or angles that no rate can be derived from."""


class DynamicsError(InputError):
    """Inertial parameters or motion data that the dynamics cannot use."""


class IdentifyError(InputError):
    """A parameter sailforce cannot fit, or a target it cannot fit to."""


class DesignError(InputError):
    """A design study that cannot be run as asked (no reachable pose, a bad range)."""


class ExportError(InputError):
    """A calibration or name that libsail cannot hold."""


class CommandError(InputError):
    """A command the server cannot carry out; its message goes back to the page."""


class SolverError(ToolError):
    """CalculiX is missing, refused the deck, or failed to solve it."""


class MeshError(ToolError):
    """gmsh could not mesh the arm (a part too small for the mesh size, a hole that does not fit)."""


class ClusterError(ToolError):
    """Dask is missing, or its scheduler cannot be reached."""


class RecordingError(ToolError):
    """A recording that could not be finished as asked (its CSV is kept)."""


class MissingExtraError(SailError, ImportError):
    """An optional dependency that a feature needs is not installed."""


class CacheEntryError(InputError):
    """A cache entry that cannot be trusted (damaged, a link, not an entry); its message says why."""
