"""``sail calibrate`` and ``sail tare``: calibration files from measurements."""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import click
import numpy as np
from rich.console import Console

from ..calfile import Calibration
from ..calibration import MODEL_KINDS, equivalent_capacity, fit_calibration
from ..errors import SailError
from ..tables import READING_COLUMNS, REFERENCE_COLUMNS, read_all
from . import cli
from ._options import load_robot, robot_option

#: ``sail tare`` warns when the no-load readings scatter by more than this
#: fraction of the cell's capacity (standard deviation): the arm was touched,
#: moved, or the cell is drifting.
TARE_SPREAD_WARNING = 0.005


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _clean_rows(path: Path, needed: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Every needed column of a calibration-type table; refuses the first row that is not a full set of numbers."""
    values, malformed, lines = read_all(path, needed)
    bad = malformed.copy()
    for name in needed:
        bad |= ~np.isfinite(values[name])
    if bad.any():
        i = int(np.argmax(bad))
        fields = ", ".join(f"{n}={values[n][i]:g}" for n in needed)
        raise SailError(
            f"{path}, line {lines[i]}: not a complete row of finite numbers ({fields}"
            f"{'; wrong number of fields' if malformed[i] else ''}); {int(bad.sum())} such row(s). "
            "Calibration data must be clean: fix or remove them"
        )
    return values


def _parse_capacity(ctx, param, value):
    if value is None:
        return None
    try:
        numbers = [float(v) for v in value.split(",")]
    except ValueError:
        numbers = []
    if len(numbers) != 2 or not all(math.isfinite(v) and v > 0 for v in numbers):
        raise click.BadParameter(f"expected two positive numbers RAW1,RAW2, got {value!r}")
    return tuple(numbers)


@cli.command("calibrate")
@click.argument("data", metavar="DATA.csv", type=click.Path(dir_okay=False, path_type=Path))
@robot_option
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True, help="Calibration JSON to write.")
@click.option("--model", "kind", type=click.Choice((*MODEL_KINDS, "auto")), default="auto", show_default=True,
              help="seed: amplitude/phase polynomials per cell; matrix: C(Δ)·Jᵀ Chebyshev map; auto: the better cross-validated.")
@click.option("--capacity", callback=_parse_capacity, default=None, metavar="RAW1,RAW2",
              help="Raw reading (offset removed) at each cell's capacity. Default: estimated from the robot's load-cell rating.")
@click.option("--load-unit", default="raw", show_default=True, help="Label of the load columns' unit, stored in the file.")
def calibrate_command(data, robot_path, output, kind, capacity, load_unit):
    """Fit offsets and the sensing map from DATA.csv (or .parquet) with reference forces.

    DATA has the columns theta1_deg, theta2_deg, load1, load2 (raw readings
    in any linear unit) and fx_N, fy_N (the applied force); other columns are
    ignored.  Record several force directions at each of several poses
    spanning the Δ = θ1 − θ2 range the robot will use.
    """
    robot = load_robot(robot_path)
    values = _clean_rows(data, READING_COLUMNS + REFERENCE_COLUMNS)
    theta1, theta2 = np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"])
    model, offsets, report = fit_calibration(robot.arm, theta1, theta2, values["fx_N"], values["fy_N"],
                                             values["load1"], values["load2"], kind=kind)  # fmt: skip
    if capacity is None:
        capacity = tuple(equivalent_capacity(model, robot.arm, robot.loadcell.capacity_N, report.delta_range))
    loads = [values["load1"], values["load2"]]
    cal = Calibration(
        robot.arm, model, tuple(map(float, offsets)), tuple(map(float, capacity)), report.delta_range,
        tuple((float(v.min()), float(v.max())) for v in loads), load_unit,
        {"fit_rmse_N": report.fit_rmse_N, "cv_rmse_N": report.cv_rmse_N, "cv_rmse_by_model_N": report.cv_rmse_by_kind,
         "n_samples": report.n_samples, "n_deltas": report.n_deltas, "model_selection": kind},
        _sha256(data),
    )  # fmt: skip
    cal.save(output)
    console = Console()
    low, high = np.degrees(report.delta_range)
    scores = ", ".join(f"{k} {v:.4g} N" for k, v in report.cv_rmse_by_kind.items())
    console.print(f"wrote {output}: model [bold]{report.kind}[/bold] from {report.n_samples} samples at "
                  f"{report.n_deltas} Δ values, Δ = {low:.4g}…{high:.4g}°")  # fmt: skip
    console.print(f"force RMSE: fit {report.fit_rmse_N:.4g} N, cross-validated {report.cv_rmse_N:.4g} N ({scores})")
    console.print(f"offsets {offsets[0]:.6g}, {offsets[1]:.6g} {load_unit}; capacity ±{capacity[0]:.4g}, ±{capacity[1]:.4g} {load_unit}")


@cli.command("tare")
@click.argument("calibration", metavar="CAL.json", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("noload", metavar="NOLOAD.csv", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True, help="New calibration JSON.")
def tare_command(calibration, noload, output):
    """New offsets from a no-load recording: the mean of its load1 and load2.

    NOLOAD has at least the columns load1 and load2, recorded with nothing
    touching the end effector.  Reports the spread (standard deviation) and
    warns when it exceeds 0.5% of a cell's capacity.
    """
    cal = Calibration.load(calibration)
    values = _clean_rows(noload, ("load1", "load2"))
    loads = np.column_stack([values["load1"], values["load2"]])
    offsets, spread = loads.mean(axis=0), loads.std(axis=0, ddof=1) if len(loads) > 1 else np.zeros(2)
    cal.with_offsets(offsets).save(output)
    console = Console()
    console.print(f"wrote {output}: offsets {offsets[0]:.6g}, {offsets[1]:.6g} {cal.load_unit} from {len(loads)} samples "
                  f"(were {cal.offsets[0]:.6g}, {cal.offsets[1]:.6g}); spread ±{spread[0]:.3g}, ±{spread[1]:.3g}")  # fmt: skip
    noisy = [i + 1 for i in range(2) if spread[i] > TARE_SPREAD_WARNING * cal.capacity[i]]
    if noisy:
        Console(stderr=True).print(
            f"[bold yellow]warning:[/bold yellow] cell(s) {', '.join(map(str, noisy))} scatter by more than "
            f"{TARE_SPREAD_WARNING:.1%} of capacity: was the arm touched or moving during the no-load recording?"
        )
