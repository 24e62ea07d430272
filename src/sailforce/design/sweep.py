"""``sail design --sweep``: every robot variant on its workspace grid, one summary row each, and the Pareto set.

A sweep is a list of axes.  Each axis is a list of *settings* (robot-file key
= value, :mod:`sailforce.io.robotkeys`): ``--sweep loadcells.position=0.2:0.8:0.1``
gives one setting per value, and a cell catalogue (:func:`read_catalogue`)
one setting per cell, its capacity, rated output and rated deflection
together.  The variants are the product of the axes, each validated as a robot
file would be before anything is computed, so a bad key or value stops the
sweep at once, naming it.

Each variant is summarised by the worst of its maps over its own grid
(:func:`evaluate`): the 1-sigma resolution, the overload (exact worst
direction), the first natural frequency (subspace iteration), the compensation
need and cond(J).  Three of them trade off: a design is on the **Pareto set**
when no other is at least as good in resolution (smaller), overload and first
frequency (larger) and better in one.  **Rank** orders the variants that meet
the requirements (an overload of at least ``required_force_N``, a first
frequency of at least ``min_frequency_Hz``) by resolution (to
:data:`RANK_DIGITS` digits), then price, first frequency and overload.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import RobotFileError, SailError
from ..fem.frame import COMPILED_MIN_POSES, compiled_solves
from ..fem.model import build_model
from ..fem.modes import arm_frequencies
from ..fem.response import simulate_model
from ..io.robotfile import NAME_KEYS
from ..io.robotkeys import get_key, with_keys
from ..kinematics import jacobian_condition
from ..robot import Robot
from ..sweep import SpecError, parse_spec
from .adc import ADC_METRICS, DEFAULT_PEAK_ACCELERATION, adc_summary
from .maps import DEFAULT_SAFETY_FACTOR, compensation_need, overload, resolution
from .study import DEFAULT_DELTA_DEG, DEFAULT_GRID, DEFAULT_THETA1_DEG, DEFAULT_THETA2_DEG, DesignError, design_grid, summarise

#: A sweep larger than this many variants is refused (a typo in a step should not start a week of work).
MAX_VARIANTS = 100_000
#: Default requirement on the overload in the worst direction [N]: a firm push on a planar rehabilitation handle.
DEFAULT_REQUIRED_FORCE_N = 45.0
#: Default requirement on the lowest first natural frequency [Hz] (0: none).
DEFAULT_MIN_FREQUENCY_HZ = 0.0
#: The catalogue's columns, and the robot-file key each sets (price and name are the catalogue's own).
CATALOGUE_KEYS = {"capacity_kg": "loadcells.capacity_kg", "rated_output_mV_V": "loadcells.rated_output_mV_V",
                  "rated_deflection_m": "loadcells.rated_deflection", "noise_mV_V": "loadcells.noise_mV_V"}  # fmt: skip
CATALOGUE_REQUIRED = ("name", "capacity_kg", "rated_output_mV_V", "rated_deflection_m", "price")
#: The summary columns of each variant, in the table's order, after its settings.
METRICS = ("poses", "resolution_N", "resolution_median_N", "overload_N", "overload_median_N", "overload_limit",
           "first_frequency_Hz", "first_frequency_median_Hz", "phase_need_deg", "amplitude_need", "condition",
           "reach_area_m2")  # fmt: skip
#: Resolutions equal to this many significant digits rank as equal: price, then frequency, then overload decide.
RANK_DIGITS = 4
#: Objectives equal to this many significant digits are equal for the Pareto set (the maps round at ~1e-12).
PARETO_DIGITS = 9
#: The Pareto objectives: (column, +1 to minimise / -1 to maximise).
OBJECTIVES = (("resolution_N", 1.0), ("overload_N", -1.0), ("first_frequency_Hz", -1.0))


@dataclass(frozen=True)
class Axis:
    """One swept dimension: a label per setting, and the robot-file keys each sets."""

    name: str  #: the key, or "cell" for a catalogue
    labels: tuple[str, ...]
    settings: tuple[dict[str, Any], ...]
    extra: tuple[dict[str, Any], ...] = ()  #: columns each setting adds to the table (a cell's price)


def parse_sweep(text: str, robot: Robot) -> Axis:
    """``KEY=start:stop:step`` (stop inclusive) or ``KEY=v1,v2,...`` into an :class:`Axis`, the key checked on ``robot``."""
    key, sep, spec = text.partition("=")
    key, spec = key.strip(), spec.strip()
    if not sep or not key or not spec:
        raise DesignError(f"--sweep {text!r}: expected KEY=start:stop:step or KEY=v1,v2,... (for example "
                          "loadcells.position=0.2:0.8:0.1)")  # fmt: skip
    try:
        current = get_key(robot, key)
    except RobotFileError as exc:
        raise DesignError(f"--sweep {key}: {exc}") from None
    items = [part.strip() for part in spec.split(",")]
    if isinstance(current, str) or key.split(".")[-1] in NAME_KEYS:
        values: list[Any] = items
    else:
        try:
            # 0.1 * 3 is 0.30000000000000004: read as written
            values = [float(f"{v:.12g}") for item in items for v in parse_spec(item, key)]
        except SpecError as exc:
            raise DesignError(f"--sweep {exc}") from None
    if len(set(values)) != len(values):
        raise DesignError(f"--sweep {key}: a value appears twice in {spec!r}")
    return Axis(key, tuple(f"{v:g}" if isinstance(v, float) else str(v) for v in values), tuple({key: v} for v in values))


def read_catalogue(path: str | Path) -> Axis:
    """A CSV of available cells: ``name, capacity_kg, rated_output_mV_V, rated_deflection_m, price`` (and
    optionally ``noise_mV_V``), one row per cell, into a ``cell`` :class:`Axis`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise DesignError(f"{path}: no such catalogue") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DesignError(f"{path}: cannot read the catalogue ({exc})") from None
    reader = csv.DictReader(text.splitlines())
    columns = [c.strip() for c in reader.fieldnames or []]
    missing = [c for c in CATALOGUE_REQUIRED if c not in columns]
    unknown = [c for c in columns if c not in CATALOGUE_REQUIRED and c not in CATALOGUE_KEYS]
    if missing or unknown:
        raise DesignError(f"{path}: the catalogue needs the columns {', '.join(CATALOGUE_REQUIRED)} (and may have "
                          f"noise_mV_V); missing {', '.join(missing) or 'none'}, unknown {', '.join(unknown) or 'none'}")  # fmt: skip
    labels, settings, extra = [], [], []
    for line, row in enumerate(reader, start=2):
        row = {k.strip(): (v or "").strip() for k, v in row.items() if k is not None}
        name = row["name"]
        if not name or name in labels:
            raise DesignError(f"{path}:{line}: each cell needs a name of its own, got {name!r}")
        numbers = {}
        for column in columns:
            if column == "name":
                continue
            try:
                numbers[column] = float(row[column])
            except ValueError:
                raise DesignError(f"{path}:{line}: {column} = {row[column]!r} is not a number") from None
            if not (math.isfinite(numbers[column]) and numbers[column] >= 0):
                raise DesignError(f"{path}:{line}: {column} = {row[column]!r} must be a non-negative number")
        labels.append(name)
        settings.append({CATALOGUE_KEYS[c]: v for c, v in numbers.items() if c in CATALOGUE_KEYS})
        extra.append({"price": numbers["price"]})
    if not labels:
        raise DesignError(f"{path}: the catalogue lists no cell")
    return Axis("cell", tuple(labels), tuple(settings), tuple(extra))


@dataclass(frozen=True)
class Variant:
    """One robot of a sweep: its labels per axis, its settings and extra columns, and the robot."""

    labels: tuple[str, ...]
    settings: dict[str, Any]
    extra: dict[str, Any]
    robot: Robot


def variants(robot: Robot, axes: Sequence[Axis]) -> list[Variant]:
    """Every combination of the axes' settings on ``robot``, each validated; a bad one is refused, naming it."""
    owner: dict[str, str] = {}
    for axis in axes:
        for key in sorted({k for setting in axis.settings for k in setting}):
            if key in owner:
                twice = f"--sweep {key} is given twice" if owner[key] == axis.name else (
                    f"{key} is set by both --sweep {owner[key] if owner[key] != 'cell' else key} and the cell catalogue")
                raise DesignError(f"{twice}: one would silently override the other; give each key once")
            owner[key] = axis.name
    total = math.prod(len(a.settings) for a in axes)
    if total > MAX_VARIANTS:
        raise DesignError(f"the sweep has {total:,} variants, more than {MAX_VARIANTS:,}: coarsen a step")
    out = []
    for picks in itertools.product(*(range(len(a.settings)) for a in axes)):
        settings: dict[str, Any] = {}
        extra: dict[str, Any] = {}
        for axis, i in zip(axes, picks):
            settings.update(axis.settings[i])
            extra.update(axis.extra[i] if axis.extra else {})
        labels = tuple(axis.labels[i] for axis, i in zip(axes, picks))
        try:
            variant = with_keys(robot, settings)
        except RobotFileError as exc:
            what = ", ".join(f"{a.name} = {label}" for a, label in zip(axes, labels))
            raise DesignError(f"--sweep: the variant {what} is not a valid robot: {exc}") from None
        out.append(Variant(labels, settings, extra, variant))
    return out


@dataclass(frozen=True)
class GridSpec:
    """How each variant's workspace grid is laid (:func:`~sailforce.design.study.design_grid`)."""

    n: int = DEFAULT_GRID
    theta1_deg: tuple[float, float] = DEFAULT_THETA1_DEG
    theta2_deg: tuple[float, float] = DEFAULT_THETA2_DEG
    delta_deg: tuple[float, float] = DEFAULT_DELTA_DEG


@dataclass(frozen=True)
class Task:
    """One variant's work, sent as is to a Dask worker."""

    robot: Robot
    grid: GridSpec = field(default_factory=GridSpec)
    safety_factor: float = DEFAULT_SAFETY_FACTOR
    peak_acceleration: float = DEFAULT_PEAK_ACCELERATION  #: of the reach a real ADC's error is measured in [m/s^2]
    compiled: bool = False  #: solve on the compiled back-end (a sweep large enough to pay for loading numba)


def evaluate(task: Task) -> dict[str, Any]:
    """The summary row (:data:`METRICS`) of one variant: the worst of each map over its grid."""
    robot, g = task.robot, task.grid
    grid = design_grid(robot, g.n, g.theta1_deg, g.theta2_deg, g.delta_deg)
    model = build_model(robot)
    with compiled_solves(task.compiled):
        response = simulate_model(model, grid.theta1, grid.theta2)
        frequency = arm_frequencies(model, grid.theta1, grid.theta2, 1)[:, 0]
    noise = resolution(response.signal("bridge"), robot.loadcell.noise_mV_V)
    over = overload(response, task.safety_factor, directions=0)
    need = compensation_need(response)
    summary = summarise(robot, grid, {
        "resolution_N": noise.worst, "overload_N": over.worst, "first_frequency_Hz": frequency,
        "phase_need_deg": need.worst_phase_deg, "amplitude_need": need.worst_amplitude,
        "condition": jacobian_condition(robot.arm, grid.theta1, grid.theta2),
    })  # fmt: skip
    extra = adc_summary(robot, task.peak_acceleration) if not robot.adc.ideal else {}
    return {
        **extra,
        "poses": int(grid.theta1.size),
        "resolution_N": summary["resolution_N"]["worst"], "resolution_median_N": summary["resolution_N"]["median"],
        "overload_N": summary["overload_N"]["worst"], "overload_median_N": summary["overload_N"]["median"],
        "overload_limit": str(over.limiting_names()[np.argmin(over.worst)]),
        "first_frequency_Hz": summary["first_frequency_Hz"]["worst"],
        "first_frequency_median_Hz": summary["first_frequency_Hz"]["median"],
        "phase_need_deg": summary["phase_need_deg"]["worst"], "amplitude_need": summary["amplitude_need"]["worst"],
        "condition": summary["condition"]["worst"], "reach_area_m2": summary["reach_m"]["area_m2"],
    }  # fmt: skip


def evaluate_safely(task: Task) -> dict[str, Any]:
    """:func:`evaluate`, with a variant the design cannot be mapped for (no reachable pose ...) as a status."""
    try:
        return {**evaluate(task), "status": "ok"}
    except SailError as exc:
        return {"status": str(exc)}


def _significant(values: np.ndarray, digits: int) -> np.ndarray:
    """``values`` rounded to ``digits`` significant digits (NaN stays NaN)."""
    return np.array([float(f"{v:.{digits}g}") for v in np.asarray(values, dtype=float)])


def pareto_mask(costs: np.ndarray) -> np.ndarray:
    """``(n,)`` True where no other row of ``costs`` ``(n, k)`` (all minimised) is <= in every column and < in one."""
    costs = np.asarray(costs, dtype=float)
    keep = np.ones(len(costs), dtype=bool)
    for start in range(0, len(costs), 1024):  # rows against all rows, in blocks of bounded memory
        block = costs[start : start + 1024, None, :]
        dominated = np.all(costs[None] <= block, axis=-1) & np.any(costs[None] < block, axis=-1)
        keep[start : start + 1024] = ~dominated.any(axis=-1)
    return keep


@dataclass(frozen=True)
class Requirements:
    """What a variant must give to be ranked: the overload and first frequency, worst over its workspace."""

    required_force_N: float = DEFAULT_REQUIRED_FORCE_N
    min_frequency_Hz: float = DEFAULT_MIN_FREQUENCY_HZ


@dataclass(frozen=True)
class SweepResult:
    """One row per variant: its axes' labels, its settings, the summary metrics, its status, Pareto flag and rank."""

    axes: tuple[Axis, ...]
    columns: dict[str, np.ndarray]
    requirements: Requirements
    seconds: float

    def __len__(self) -> int:
        return len(self.columns["variant"])

    @property
    def pareto(self) -> np.ndarray:
        return self.columns["pareto"]

    def ranked(self) -> np.ndarray:
        """Row indices of the ranked variants, best first."""
        rank = self.columns["rank"]
        rows = np.flatnonzero(rank > 0)
        return rows[np.argsort(rank[rows])]


def run_sweep(robot: Robot, axes: Sequence[Axis], *, grid: GridSpec | None = None,
              safety_factor: float = DEFAULT_SAFETY_FACTOR, requirements: Requirements | None = None,
              workers: int | None = None, scheduler: str | None = None,
              advance: Callable[[float], None] | None = None) -> SweepResult:  # fmt: skip
    """Evaluate every variant (in this process, or on Dask: :func:`~sailforce.distributed.run_tasks`)."""
    import time

    from ..distributed import run_tasks

    if not axes:
        raise DesignError("a sweep needs at least one --sweep KEY=VALUES or a --capacity-catalogue")
    requirements = requirements or Requirements()
    grid = grid or GridSpec()
    started = time.perf_counter()
    todo = variants(robot, axes)
    compiled = len(todo) * grid.n**2 >= COMPILED_MIN_POSES  # the whole sweep's poses, about: worth loading numba for
    tasks = [Task(v.robot, grid, safety_factor, compiled=compiled) for v in todo]
    outcomes = run_tasks(evaluate_safely, tasks, workers=workers, scheduler=scheduler, advance=advance)
    rows = [o.value if o.ok else {"status": f"failed: {o.error}"} for o in outcomes]
    columns: dict[str, np.ndarray] = {"variant": np.arange(len(todo))}
    for a, axis in enumerate(axes):
        values = [v.labels[a] if axis.name == "cell" else v.settings[axis.name] for v in todo]
        columns[axis.name] = np.array(values, dtype=float if all(isinstance(x, float) for x in values) else str)
    for key in sorted({k for axis in axes if axis.name == "cell" for s in axis.settings for k in s}):
        columns[key] = np.array([float(v.settings[key]) for v in todo])
    for key in sorted({k for v in todo for k in v.extra}):
        columns[key] = np.array([float(v.extra.get(key, np.nan)) for v in todo])
    real_adc = any(not v.robot.adc.ideal for v in todo)
    for metric in METRICS + (ADC_METRICS if real_adc else ()):
        text = metric == "overload_limit"
        columns[metric] = np.array([row.get(metric, "" if text else np.nan) for row in rows],
                                   dtype=object if text else float)  # fmt: skip
    columns["overload_limit"] = columns["overload_limit"].astype(str)
    status = np.array([row["status"] for row in rows])
    ok = status == "ok"
    pareto = np.zeros(len(todo), dtype=bool)
    costs = np.stack([sign * _significant(columns[name], PARETO_DIGITS) for name, sign in OBJECTIVES], axis=-1)
    pareto[ok] = pareto_mask(costs[ok])
    meets = ok & (columns["overload_N"] >= requirements.required_force_N)
    meets &= columns["first_frequency_Hz"] >= requirements.min_frequency_Hz
    rank = np.zeros(len(todo), dtype=int)
    price = columns.get("price", np.zeros(len(todo)))
    keys = [columns["resolution_N"], price, -columns["first_frequency_Hz"], -columns["overload_N"]]
    keys[0] = _significant(keys[0], RANK_DIGITS)  # equal to rounding: let price decide
    order = np.lexsort(tuple(k[meets] for k in reversed(keys)))
    rank[np.flatnonzero(meets)[order]] = np.arange(1, meets.sum() + 1)
    columns.update(pareto=pareto, rank=rank, status=status)
    return SweepResult(tuple(axes), columns, requirements, time.perf_counter() - started)
