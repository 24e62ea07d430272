"""Moved to :mod:`sailforce.stream.motion`: this path works for one release, with a warning."""

from .._moved import moved

__getattr__ = moved(__name__, "sailforce.stream.motion")
