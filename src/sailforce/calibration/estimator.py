"""Moved to :mod:`sailforce.estimate.estimator`: this path works for one release, with a warning."""

from .._moved import moved

__getattr__ = moved(__name__, "sailforce.estimate.estimator")
