"""Options shared by several commands."""

from __future__ import annotations

from pathlib import Path

import click

from ..arm import Arm


def robot_option(func):
    """``--robot FILE``: the robot file; the default robot when absent."""
    return click.option(
        "--robot",
        "robot_path",
        type=click.Path(dir_okay=False, path_type=Path),
        default=None,
        help="Robot TOML file (see `sail robot init`). Default: the built-in robot.",
    )(func)


def load_arm(robot_path: Path | None) -> Arm:
    """The arm described by ``--robot``, or the default :class:`Arm`."""
    return Arm() if robot_path is None else Arm.from_toml(robot_path)
