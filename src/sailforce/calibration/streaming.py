"""Moved to :mod:`sailforce.stream.pipeline`: this path works for one release, with a warning."""

from .._moved import moved

__getattr__ = moved(__name__, "sailforce.stream.pipeline")
