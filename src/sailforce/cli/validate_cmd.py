"""``sail validate``: a calibration's force against a reference six-axis sensor's, the table a paper needs."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from ..calibration.file import Calibration
from ..io.files import check_output, write_figure, write_json, write_numeric_table
from ..reference.validate import DELTA_BIN_DEG, LIMITS_SD, REGION_M, Agreement, Binned
from ..status import STATUS_NAMES, count_statuses
from ..workflows import Validation, validation
from . import cli
from ._options import load_robot, reference_options, robot_option
from .calibrate_cmd import _offsets

#: Files ``sail validate`` writes into its output directory.
OUTPUTS = ("validation.json", "by_delta.csv", "by_region.csv", "bland_altman.png", "error_map.png")
#: The columns of by_delta.csv and by_region.csv after their bin columns.
AGREEMENT_COLUMNS = ("samples", "rmse_N", "p95_N", "max_N", "bias_fx_N", "bias_fy_N", "sd_fx_N", "sd_fy_N")


@cli.command("validate")
@click.argument("data", metavar="DATA.csv", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--reference", "reference", type=click.Path(dir_okay=False, path_type=Path), required=True,
              metavar="REF.csv", help="The reference sensor's recording of the same session (t_s, fx, fy, ... in its "
              "own frame, on its own clock).")  # fmt: skip
@click.option("--calibration", "calibration", type=click.Path(dir_okay=False, path_type=Path), required=True,
              metavar="CAL.json", help="The calibration to validate.")
@robot_option
@reference_options
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path), required=True,
              help=f"Directory for {', '.join(OUTPUTS)} (created if needed).")
def validate_command(data, reference, calibration, robot_path, reference_on, reference_offsets, max_clock_offset, output):
    """Validate CAL.json on DATA.csv against a reference F/T sensor's recording.

    DATA is the robot's recording (t_s, theta1_deg, theta2_deg, load1,
    load2, a reading at every tick).  The reference is registered as `sail
    calibrate --reference` does it (its clock by cross-correlation, its
    mount and offsets from the rigid statics at rest, never from CAL), and
    SAIL's force, with CAL's dynamic term if it has one, is set against it:
    bias, spread, 95 % limits of agreement (Bland-Altman), RMS and 95th
    percentile of the error, overall, at rest and moving, per Δ bin and per
    square of the workspace.  Writes into DIR: validation.json (every
    number), by_delta.csv, by_region.csv, bland_altman.png, error_map.png.
    """
    for path in OUTPUTS:
        check_output(output / path, {"DATA": data, "the --reference recording": reference, "CAL.json": calibration,
                                     "the --robot file": robot_path}, flag=f"-o {output}:")  # fmt: skip
    cal = Calibration.load(calibration)
    robot = load_robot(robot_path) if robot_path is not None else None
    v = validation(data, reference, cal, robot=robot, on=reference_on, max_offset_s=max_clock_offset,
                   offsets_N=reference_offsets)  # fmt: skip
    output.mkdir(parents=True, exist_ok=True)
    _write(output, v, data, reference, calibration)
    _print(Console(), v, output)


def _summary(v: Validation, data: Path, reference: Path, calibration: Path) -> dict:
    a, f = v.rows.alignment, v.rows.frame
    part = lambda x: None if x is None else x.to_dict()
    return {
        "data": str(data), "reference": str(reference), "calibration": str(calibration),
        "dynamic_term": v.dynamics, "samples": int(v.status.size), "outside_reference": v.rows.dropped,
        "statuses": {name: int(n) for name, n in zip(STATUS_NAMES, count_statuses(v.status))},
        "clock_offset_s": a.offset_s, "alignment_score": a.score, "mount_deg": float(np.degrees(f.mount_rad)),
        "mount_se_deg": float(np.degrees(f.mount_se_rad)), "reference_offsets_N": list(f.offsets_N),
        "reference_offsets_se_N": list(f.offsets_se_N), "reference_offsets_fitted": f.offsets_fitted, "on": f.on,
        "limits_sd": LIMITS_SD, "overall": part(v.overall), "at_rest": part(v.at_rest), "moving": part(v.moving),
        "extrapolated": part(v.extrapolated),
        "by_delta": [{"delta_low_deg": e[0], **x.to_dict()} for e, x in zip(v.by_delta.edges, v.by_delta.agreements)],
        "by_region": [{"x_low_m": e[0], "y_low_m": e[1], **x.to_dict()} for e, x in zip(v.by_region.edges, v.by_region.agreements)],
    }  # fmt: skip


def _rows(binned: Binned) -> np.ndarray:
    return np.array([[*e, x.samples, x.rmse_N, x.p95_N, x.max_N, *x.bias_N, *x.sd_N]
                     for e, x in zip(binned.edges, binned.agreements)]).reshape(len(binned.edges), -1)  # fmt: skip


def _write(output: Path, v: Validation, data: Path, reference: Path, calibration: Path) -> None:
    from ..report.validation_figure import bland_altman_figure, error_map_figure

    write_json(output / "validation.json", _summary(v, data, reference, calibration))
    write_numeric_table(output / "by_delta.csv", ("delta_low_deg", *AGREEMENT_COLUMNS), _rows(v.by_delta))
    write_numeric_table(output / "by_region.csv", ("x_low_m", "y_low_m", *AGREEMENT_COLUMNS), _rows(v.by_region))
    write_figure(output / "bland_altman.png", bland_altman_figure(v), dpi=110)
    write_figure(output / "error_map.png", error_map_figure(v), dpi=110)


def _print(console: Console, v: Validation, output: Path) -> None:
    a, f = v.rows.alignment, v.rows.frame
    console.print(f"reference: clock {a.offset_s * 1e3:+.3f} ms, mount {np.degrees(f.mount_rad):.3f} ± "
                  f"{np.degrees(f.mount_se_rad):.3f}° on the {f.on}, offsets {_offsets(f)}; "
                  f"CAL {'with' if v.dynamics else 'without'} a dynamic term", highlight=False)  # fmt: skip
    table = Table(title=f"SAIL against the reference, mN; limits of agreement: bias ± {LIMITS_SD:g} SD")
    for head in ("", "samples", "RMS", "95 %", "bias fx", "bias fy", "± fx", "± fy"):
        table.add_column(head, justify="left" if not head else "right", no_wrap=True)
    parts: list[tuple[str, Agreement | None]] = [("all ok", v.overall), ("at rest", v.at_rest), ("moving", v.moving),
                                                 ("Δ beyond CAL", v.extrapolated)]  # fmt: skip
    parts += [(f"Δ {e[0]:.0f}-{e[0] + DELTA_BIN_DEG:.0f}°", x) for e, x in zip(v.by_delta.edges, v.by_delta.agreements)]
    for name, x in parts:
        if x is None:
            continue
        table.add_row(name, f"{x.samples:,}", f"{x.rmse_N * 1e3:.1f}", f"{x.p95_N * 1e3:.1f}", f"{x.bias_N[0] * 1e3:+.1f}",
                      f"{x.bias_N[1] * 1e3:+.1f}", f"{LIMITS_SD * x.sd_N[0] * 1e3:.0f}", f"{LIMITS_SD * x.sd_N[1] * 1e3:.0f}")  # fmt: skip
    console.print(table)
    flagged = {n: int(c) for n, c in zip(STATUS_NAMES, count_statuses(v.status)) if n != "ok" and c}
    if flagged:
        console.print("not in 'all': " + ", ".join(f"{c:,} {n}" for n, c in flagged.items()), highlight=False)
    console.print(f"{len(v.by_region.edges)} squares of {REGION_M * 100:g} cm in by_region.csv; wrote "
                  f"{', '.join(str(output / n) for n in OUTPUTS)}", highlight=False)  # fmt: skip
