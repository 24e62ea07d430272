"""The study's numbers as files: ``table4.csv`` and ``results.json``, and the seed's published values."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np

from .._version import __version__
from ..io.files import write_json, write_numeric_table
from ..paper.seed import SEED_PRESCALE, SEED_REGRESSORS, SEED_RMSE, seed_table4  # noqa: F401  (re-exported: the report's seed values)
from ..paper.study import TABLE4_COLUMNS, TABLE4_FORMAT, StudyResult


def write_table4(path: Path, table: np.ndarray) -> None:
    """``table4.csv``: delta_deg, amplitude_1, phase_1_deg, amplitude_2, phase_2_deg."""
    write_numeric_table(path, TABLE4_COLUMNS, table, csv_format=TABLE4_FORMAT)


def results_dict(result: StudyResult) -> dict[str, object]:
    """The content of ``results.json`` (the seed's results, plus what goes beyond the seed)."""
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
