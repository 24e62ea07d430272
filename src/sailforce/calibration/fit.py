"""Moved to :mod:`sailforce.fit.calibration`: this path works for one release, with a warning."""

from .._moved import moved

__getattr__ = moved(__name__, "sailforce.fit.calibration")
