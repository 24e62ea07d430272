"""How the report and its figures name and colour the study's models: display only, kept apart from the ids."""

from __future__ import annotations

from ..study import ModelId, Protocol, span_deg

#: The models' display colours, one per :class:`~sailforce.study.ModelId`.
MODEL_COLOURS = {
    ModelId.UNCOMPENSATED: "tab:red",
    ModelId.SEED: "tab:blue",
    ModelId.MATRIX: "tab:green",
    ModelId.MATRIX_WIDE: "tab:purple",
}


def model_label(model: ModelId, protocol: Protocol) -> str:
    """The display label of ``model``; the wide matrix model names the span it was calibrated on."""
    if model is ModelId.MATRIX_WIDE:
        return f"matrix, calibrated Δ = {span_deg(protocol.wide_calibration_delta_deg)}"
    return {
        ModelId.UNCOMPENSATED: "uncompensated (k × load)",
        ModelId.SEED: "seed (gain and phase per cell)",
        ModelId.MATRIX: "matrix (2×2 map in Δ)",
    }[model]
