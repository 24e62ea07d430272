"""Moved to :mod:`sailforce.export_c`: this path works for one release, with a warning."""

from .._moved import moved

__getattr__ = moved(__name__, "sailforce.export_c")
