"""The rig: checks of what a real rig records (``sail check-rig``)."""

from .check import CellTiming, Link, RigCheck, check_rig

__all__ = ["CellTiming", "Link", "RigCheck", "check_rig"]
