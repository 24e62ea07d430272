"""The study's numbers as files: ``table4.csv`` and ``results.json``, and the seed's published values."""

from __future__ import annotations

import csv
from dataclasses import asdict
from importlib.resources import files
from pathlib import Path

import numpy as np

from .. import __version__
from ..io.files import atomic_writer, read_numeric_csv, write_json
from ..study import TABLE4_COLUMNS, StudyResult

#: The seed's published regressors (Section 3, after Table 4), highest power first.
SEED_REGRESSORS = {
    "amplitude_1": (6.836e-06, -0.002404, 0.325, -19.43, 1145.0),
    "phase_1_deg": (1.33e-07, -4.438e-05, 0.004638, -0.1106, 3.479),
    "amplitude_2": (1.262e-05, -0.003925, 0.4893, -26.68, 1040.0),
    "phase_2_deg": (0.0009928, -0.4999, 6.749),
}
#: The seed's validation RMSEs (Section 3), torque units, its curves pre-scaled by 740 and 528.
SEED_RMSE = {"before": {"t1": 0.436, "t2": 0.696, "mean": 0.566}, "after": {"t1": 0.016, "t2": 0.09, "mean": 0.053}}
SEED_PRESCALE = (740.0, 528.0)


def seed_table4() -> np.ndarray:
    """The seed's Table 4, shipped as ``sailforce/data/seed_table4.csv``: (8, 5), :data:`TABLE4_COLUMNS`."""
    path = files("sailforce") / "data" / "seed_table4.csv"
    names, table = read_numeric_csv(Path(str(path)))
    assert tuple(names) == TABLE4_COLUMNS, names
    return table


def write_table4(path: Path, table: np.ndarray) -> None:
    """``table4.csv``: delta_deg, amplitude_1, phase_1_deg, amplitude_2, phase_2_deg."""
    with atomic_writer(path) as stream:
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(TABLE4_COLUMNS)
        writer.writerows([[f"{v:.10g}" for v in row] for row in table])


def results_dict(result: StudyResult) -> dict[str, object]:
    """The content of ``results.json`` (issue 4, item 1f, plus what goes beyond the seed)."""
    amplitude = result.torque_amplitude
    return {
        "software": f"sailforce {__version__}",
        "joints": result.robot.joints.label,
        "transduction": result.transduction,
        "robot": asdict(result.robot),
        "protocol": asdict(result.protocol),
        "criterion": result.criterion,
        "threshold": result.threshold,
        "prescale": {"load_cell_1": result.prescale[0], "load_cell_2": result.prescale[1],
                     "unit": "N m per signal unit", "seed": list(SEED_PRESCALE)},
        "table4": [dict(zip(TABLE4_COLUMNS, map(float, row))) for row in result.table4],
        "regressors": {name: fit.as_dict() for name, fit in result.regressors.items()},
        "rmse": {"before": result.rmse_before.as_dict(), "after": result.rmse_after.as_dict(), "unit": "N m"},
        "rmse_relative": {"before": result.rmse_before.relative(amplitude).as_dict(),
                          "after": result.rmse_after.relative(amplitude).as_dict(),
                          "amplitude_Nm": list(amplitude)},
        "rmse_after_estimator": result.rmse_after_estimator.as_dict(),
        "delta_only_discrepancy": result.delta_only_discrepancy,
        "seed": {"rmse": SEED_RMSE, "regressors": {k: list(v) for k, v in SEED_REGRESSORS.items()}},
        "beyond_seed": {
            "matrix_compensator": {"order": result.matrix_compensator.order,
                                   "cv_force_rmse_N": list(result.matrix_compensator.cv_rmse),
                                   "delta_range_deg": np.degrees(result.matrix_compensator.delta_range).tolist()},
            "rmse_matrix": result.rmse_matrix.as_dict(),
            "force_rmse_N": result.force_rmse,
            "workspace": {"delta_deg": np.degrees(result.workspace.delta).tolist(),
                          "relative_force_error": {k: v.tolist() for k, v in result.workspace.relative_error.items()}},
        },
        "timings_s": result.timings,
    }  # fmt: skip


def write_results(directory: Path, result: StudyResult) -> None:
    """Write ``table4.csv`` and ``results.json`` into ``directory``."""
    write_table4(directory / "table4.csv", result.table4)
    write_json(directory / "results.json", results_dict(result))
