"""The rig: checks of what a real rig records (``sail check-rig``)."""

from .check import CellTiming, RigCheck, check_rig

__all__ = ["CellTiming", "RigCheck", "check_rig"]
