"""Moved to :mod:`sailforce.estimate.dynamic` and :mod:`sailforce.fit.dynamic`: this path works for one release, with a warning."""

from .._moved import moved

__getattr__ = moved(__name__, "sailforce.estimate.dynamic", "sailforce.fit.dynamic")
