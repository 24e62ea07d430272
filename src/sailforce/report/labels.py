"""How the report and its figures name and colour the study's models: display only, kept apart from the ids."""

from __future__ import annotations

from ..paper.study import ModelId, Protocol, span_deg
from ..robot import LINK_NAMES, Robot


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown pipe table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def links_label(robot: Robot) -> str:
    """``"links 25 × 10 mm plain carbon steel"``, or per link where any link has its own section or material."""
    def one(section, material) -> str:
        return f"{section.depth * 1e3:g} × {section.thickness * 1e3:g} mm {material.name}"

    if robot.uniform_links:
        return "links " + one(robot.link_section, robot.link_material)
    return "links " + "; ".join(f"{n} {one(robot.section(n), robot.material(n))}" for n in LINK_NAMES)


#: The models' display colours, one per :class:`~sailforce.paper.study.ModelId`.
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
