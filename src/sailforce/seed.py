"""Moved to :mod:`sailforce.paper.seed`: this path works for one release, with a warning."""

from ._moved import moved

__getattr__ = moved(__name__, "sailforce.paper.seed")
