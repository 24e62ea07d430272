"""Exceptions raised by sailforce.

Every error is a :class:`SailError`, itself a :class:`ValueError`, so callers
can catch one type.  Messages say what was expected and what arrived, because
the CLI prints them verbatim as its one-line error.
"""

from __future__ import annotations


class SailError(ValueError):
    """Base class of every error sailforce raises on bad input."""


class ShapeError(SailError):
    """An array argument has the wrong shape or cannot be broadcast."""


class NonFiniteInputError(SailError):
    """An array argument holds NaN or infinity where a number is required."""


class GeometryError(SailError):
    """Link lengths that cannot form the SAIL parallelogram."""


class RobotFileError(SailError):
    """A robot TOML file is missing, malformed, or describes an impossible arm."""


class UnreachablePointError(SailError):
    """An end-effector position lies outside the arm's annular workspace."""


class SingularPoseError(SailError):
    """A pose where |sin(theta1 - theta2)| is too small to invert J^T.

    There the parallelogram is (nearly) collapsed, and the end-effector force
    error grows as 1/|sin(theta1 - theta2)| (docs/errata.md, Statics).
    """
