"""Options shared by several commands."""

from __future__ import annotations

from pathlib import Path

import click

from ..arm import Arm
from ..robot import JOINT_MODELS, Robot
from ..robotfile import load_robot_file
from ..sweep import parse_spec


def robot_option(func):
    """``--robot FILE``: the robot file; the default robot when absent."""
    return click.option(
        "--robot",
        "robot_path",
        type=click.Path(dir_okay=False, path_type=Path),
        default=None,
        help="Robot TOML file (see `sail robot init`). Default: the built-in robot.",
    )(func)


def joints_option(func):
    """``--joints``: overrides the robot file's joint model."""
    return click.option(
        "--joints",
        type=click.Choice(JOINT_MODELS),
        default=None,
        help="Passive-joint model; overrides the robot file (default there: pin).",
    )(func)


def load_arm(robot_path: Path | None) -> Arm:
    """The arm described by ``--robot``, or the default :class:`Arm`."""
    return Arm() if robot_path is None else Arm.from_toml(robot_path)


def load_robot(robot_path: Path | None, joints: str | None = None) -> Robot:
    """The structure described by ``--robot`` (default robot if None), with ``--joints`` applied."""
    robot = Robot() if robot_path is None else load_robot_file(robot_path).robot
    return robot if joints is None else robot.with_joints(joints)


def spec(name: str):
    """A click callback reading a sweep SPEC (``A`` or ``start:stop:step``) in degrees."""

    def callback(ctx, param, value):
        if value is None:
            return None
        try:
            return parse_spec(value, name)
        except ValueError as exc:
            raise click.BadParameter(str(exc)) from None

    return callback


def lowpass_options(func):
    """``--lowpass-hz``, ``--sample-rate-hz``, ``--lowpass-order``: a Butterworth low-pass on the loads."""
    func = click.option("--lowpass-order", type=click.IntRange(1, 8), default=2, show_default=True, help="Butterworth order.")(func)
    func = click.option("--sample-rate-hz", type=float, default=None, help="Sample rate of the readings [Hz].")(func)
    return click.option("--lowpass-hz", type=float, default=None,
                        help="Butterworth low-pass cutoff on the loads [Hz]; needs --sample-rate-hz.")(func)  # fmt: skip


def make_lowpass(lowpass_hz: float | None, sample_rate_hz: float | None, order: int):
    """The :class:`sailforce.filters.LowPass` the options ask for, or None."""
    if lowpass_hz is None:
        return None
    if sample_rate_hz is None:
        raise click.BadParameter("needs --sample-rate-hz", param_hint="--lowpass-hz")
    from ..filters import LowPass

    return LowPass(lowpass_hz, sample_rate_hz, order)
