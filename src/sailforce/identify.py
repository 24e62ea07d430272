"""Moved to :mod:`sailforce.fit.identify` and :mod:`sailforce.paper.table4_fit`: this path works for one release, with a warning."""

from ._moved import moved

__getattr__ = moved(__name__, "sailforce.fit.identify", "sailforce.paper.table4_fit")
