"""The study's numbers as files: ``table4.csv`` and ``results.json``, and the seed's published values."""

from __future__ import annotations

import csv
from dataclasses import asdict
from pathlib import Path

import numpy as np

from .. import __version__
from ..io.files import atomic_writer, write_json
from ..seed import SEED_PRESCALE, SEED_REGRESSORS, SEED_RMSE, seed_table4  # noqa: F401  (re-exported: the report's seed values)
from ..study import TABLE4_COLUMNS, StudyResult


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
