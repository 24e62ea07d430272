"""Options shared by several commands.

Flag names carry their unit as its SI symbol, as file columns do:
``--theta1-deg``, ``--force-N``, ``--t1-Nm``, ``--lowpass-Hz``.  Older
spellings (``--t1``, ``--lowpass-hz``) still work but are not shown.
"""

from __future__ import annotations

import math
from pathlib import Path

import click

from ..arm import Arm
from ..io import robotfile
from ..io.robotfile import load_robot_file
from ..robot import JOINT_MODELS, Robot
from ..sweep import parse_spec


class PrimaryOption(click.Option):
    """An option whose help shows only its first spelling; the others are kept for old scripts."""

    def get_help_record(self, ctx):
        spellings = self.opts
        self.opts = spellings[:1]
        try:
            return super().get_help_record(ctx)
        finally:
            self.opts = spellings


class FiniteFloat(click.ParamType):
    """A float that is neither NaN nor infinite; the error names the flag."""

    name = "number"

    def convert(self, value, param, ctx):
        try:
            number = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return number


FINITE = FiniteFloat()


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
    return Arm() if robot_path is None else robotfile.load_arm(robot_path)


def load_robot(robot_path: Path | None, joints: str | None = None) -> Robot:
    """The structure described by ``--robot`` (default robot if None), with ``--joints`` applied.

    Values the file may hold but no arm a hand holds has (a section 1e6 m deep) are warned about on stderr.
    """
    robot = Robot() if robot_path is None else _robot_file(robot_path)
    return robot if joints is None else robot.with_joints(joints)


def _robot_file(robot_path: Path) -> Robot:
    from rich.console import Console

    from ..io.robotkeys import plausibility_warnings

    robot = load_robot_file(robot_path).robot
    for warning in plausibility_warnings(robot):
        Console(stderr=True).print(f"[bold yellow]warning:[/bold yellow] {robot_path}: {warning}", highlight=False, soft_wrap=True)
    return robot


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
    """``--lowpass-Hz``, ``--sample-rate-Hz``, ``--lowpass-order``: a Butterworth low-pass on the loads."""
    func = click.option("--lowpass-order", type=click.IntRange(1, 8), default=None,
                        help="Butterworth order (default 2).")(func)  # fmt: skip
    func = click.option("--sample-rate-Hz", "--sample-rate-hz", "sample_rate_hz", cls=PrimaryOption, type=FINITE,
                        default=None, help="Sample rate of the readings [Hz]; goes with --lowpass-Hz.")(func)  # fmt: skip
    return click.option("--lowpass-Hz", "--lowpass-hz", "lowpass_hz", cls=PrimaryOption, type=FINITE, default=None,
                        help="Butterworth low-pass cutoff on the loads [Hz]; needs --sample-rate-Hz.")(func)  # fmt: skip


def make_lowpass(lowpass_hz: float | None, sample_rate_hz: float | None, order: int | None, *,
                 rate_alone: bool = False):  # fmt: skip
    """The :class:`sailforce.estimate.filters.LowPass` the options ask for, or None (``rate_alone``: the rate has another use)."""
    if lowpass_hz is None:
        if (sample_rate_hz is not None and not rate_alone) or order is not None:
            given = "--sample-rate-Hz" if sample_rate_hz is not None else "--lowpass-order"
            raise click.UsageError(f"{given} configures the low-pass, which needs --lowpass-Hz; without it nothing is filtered")
        return None
    if sample_rate_hz is None:
        raise click.BadParameter("needs --sample-rate-Hz", param_hint="--lowpass-Hz")
    from ..estimate.filters import LowPass

    return LowPass(lowpass_hz, sample_rate_hz, 2 if order is None else order)


def resolve_reading(robot: Robot, option: str | None, default: str, console, flag: str = "--transduction") -> str:
    """The cells' reading: the option if given (saying so when it overrides the robot file's), else the file's, else ``default``."""
    stated = robot.loadcell.reading
    if option is None:
        return stated or default
    if stated and option != stated:
        console.print(f"note: {flag} {option} overrides the robot file's reading = {stated!r}", highlight=False, soft_wrap=True)
    return option


def robot_with_joints(robot_path: Path | None, joints: str | None, default: str, console) -> Robot:
    """``--robot`` with ``--joints``: the file's own joints unless ``--joints`` is given (then say that it overrides them).

    Without a robot file, ``default`` (the command's own) applies.
    """
    if robot_path is None:
        return Robot().with_joints(joints or default)
    robot = _robot_file(robot_path)
    if joints is None:
        return robot
    if robot.joints.label != joints:
        console.print(f"note: --joints {joints} overrides the robot file's joints ({robot.joints.label})", highlight=False, soft_wrap=True)
    return robot.with_joints(joints)


#: Link lengths of a calibration and a robot file agree within this [relative]: a file rounds them to 12 digits at most.
SAME_ARM_RTOL = 1e-9


def check_same_arm(cal_arm: Arm, robot_arm: Arm, robot_path: Path | None) -> None:
    """Refuse a calibration made for another arm than the ``--robot`` file's (their forces would differ without a word)."""
    names = ("l1", "l2", "l3", "l4")
    ours, theirs = [getattr(cal_arm, n) for n in names], [getattr(robot_arm, n) for n in names]
    if not all(math.isclose(a, b, rel_tol=SAME_ARM_RTOL) for a, b in zip(ours, theirs)):
        show = lambda values: ", ".join(f"{n} = {v:g}" for n, v in zip(names, values))
        where = robot_path if robot_path is not None else "the default robot"
        raise click.UsageError(f"the calibration is for another arm ({show(ours)} m) than {where} ({show(theirs)} m); "
                               "give the robot file it was made with, or recalibrate")  # fmt: skip


def file_only(ctx, param, value):
    """A click callback for outputs that must be files: ``-`` (standard output) would otherwise name a file ``-``."""
    if value is not None and str(value) == "-":
        raise click.BadParameter("'-' is not standard output here: this output is written to a file; name one")
    return value


def readings_parquet(table, stack) -> Path:
    """A table read from a bag or an XDF file as a Parquet file in a temporary folder that lives as long as ``stack``
    (a :class:`contextlib.ExitStack`): the file pipeline's input."""
    import tempfile

    import pyarrow.parquet as pq

    folder = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="sail-readings-")))
    pq.write_table(table, folder / "readings.parquet")
    return folder / "readings.parquet"


def bag_topic_options(func):
    """``--joint-topic`` and ``--load-topic``: the topics a ROS 2 bag's readings are read from (sailforce.io.rosbag)."""
    func = click.option("--load-topic", default="/sail/loads", show_default=True,
                        help="IN.mcap: the std_msgs/msg/Float64MultiArray [load1, load2] topic, paired with the joint "
                             "state of the same stamp.")(func)  # fmt: skip
    return click.option("--joint-topic", default="/joint_states", show_default=True,
                        help="IN.mcap (or a rosbag2 folder): the sensor_msgs/msg/JointState topic of the angles "
                             "[rad].")(func)  # fmt: skip


def latency_option(func):
    """``--source-latency-ms``: the readings' known age when they arrive, taken off their LSL stamps."""
    return click.option("--source-latency-ms", "latency_ms", type=FINITE, default=0.0, show_default=True, metavar="MS",
                        help="--lsl-out: how old each reading is when its line arrives (the device's own delay, USB "
                             "buffering), taken off its LSL stamp; a serial line's transmission time at --baud is "
                             "taken off as well.")(func)  # fmt: skip


def number_pair(value: str | None, *, positive: bool, expected: str) -> tuple[float, float] | None:
    """Two finite numbers ``A,B`` from an option (positive ones, if ``positive``), or a clear error naming ``expected``."""
    if value is None:
        return None
    try:
        numbers = [float(v) for v in value.split(",")]
    except ValueError:
        numbers = []
    if len(numbers) != 2 or not all(math.isfinite(v) and (v > 0 or not positive) for v in numbers):
        raise click.BadParameter(f"expected {expected}, got {value!r}")
    return numbers[0], numbers[1]


def _reference_offsets(ctx, param, value):
    return number_pair(value, positive=False, expected="two numbers FX,FY in newtons, e.g. 0,0")


def reference_options(function):
    """--reference-on, --reference-offsets-N and --max-clock-offset-s: how a reference sensor's recording is read."""
    from ..reference.align import MAX_CLOCK_OFFSET_S
    from ..reference.sensor import MOUNTS

    for option in reversed((
        click.option("--reference-on", "reference_on", type=click.Choice(MOUNTS), default="link", show_default=True,
                     help="The reference sensor turns with the handle's link (theta1), or sits on the base."),
        click.option("--reference-offsets-N", "--reference-offsets-n", "reference_offsets", default=None,
                     metavar="FX,FY", callback=_reference_offsets,
                     help="The sensor's in-plane offsets [N], fixed (0,0 for a sensor tared before the session). "
                          "Default: fitted, with their standard errors reported."),
        click.option("--max-clock-offset-s", "max_clock_offset", type=click.FloatRange(0.0, min_open=True),
                     default=MAX_CLOCK_OFFSET_S, show_default=True,
                     help="The largest clock offset searched between the two recordings [s]."),
    )):  # fmt: skip
        function = option(function)
    return function
