"""The report's section "What was the seed's model?": its text, its figure and ``seed_model.json``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..fit.identify import get_parameter
from ..io.files import write_figure, write_json
from ..paper.seed import SEED_PRESCALE, SEED_RMSE
from ..paper.seed_model import (
    TARGET_PHASE_RMS_DEG,
    TARGET_SHAPE_RMS,
    FamilyFit,
    SeedModelResult,
    interior_minimum,
    shape,
)
from ..paper.study import StudyResult, table4
from .labels import markdown_table


def _finite(value: float) -> float | None:
    """JSON has no NaN: an undefined standard error is written as null."""
    return float(value) if math.isfinite(value) else None


def _value(name: str, value: float, se: float) -> str:
    error = f"± {se:.2g}" if math.isfinite(se) else "± undefined"
    short = name.replace("joints.", "").replace("loadcells.", "").replace("links.", "").replace(".stiffness", " k")
    if "stiffness" in name:
        return f"{short} = {value:.3g} N·m/rad ({error})"
    unit = " m" if name.startswith("links.") else ""
    return f"{short} = {value:.3g}{unit} ({error})"


def _bounds(fit: FamilyFit) -> str:
    return "; ".join(f"{name.split('.')[-1] if 'stiffness' not in name else name.split('.')[-2]} {low:.3g}…{high:.3g}"
                     for name, (low, high) in zip(fit.fit.names, fit.fit.bounds))  # fmt: skip


def _rms(pair: tuple[float, float], percent: bool = False) -> str:
    if any(math.isnan(v) for v in pair):
        return "–"
    return " / ".join(f"{100 * v:.1f} %" if percent else f"{v:.2f}°" for v in pair)


def _minimum(fit: FamilyFit) -> str:
    return " / ".join("yes" if interior_minimum(fit.table, cell) else "no" for cell in (1, 2))


def _residual_table(fit: FamilyFit) -> str:
    columns = fit.fit.residual_columns
    header = ["Δ [deg]", *columns]
    rows = [[f"{d:g}", *(f"{v:+.3f}" for v in row)] for d, row in zip(fit.table[:, 0], fit.fit.residuals)]
    return markdown_table(header, rows)


def seed_model_section(result: SeedModelResult, main: StudyResult) -> str:
    """The Markdown section; ``main`` is the reproduced study whose phases are compared with the seed's."""
    fits = result.fits
    closest = result.closest
    phases_only = [f for f in fits if f.family.amplitude_weight == 0]
    rows = [[f"**{f.family.name}**", f.family.description, "<br>".join(_value(n, v, s) for n, v, s in
             zip(f.fit.names, f.fit.values, f.fit.standard_errors)), _rms(f.fit.phase_rms_deg),
             _rms(f.fit.shape_rms, percent=True), _minimum(f),
             ", ".join(n.split(".")[-2] if "stiffness" in n else n.split(".")[-1]
                       for n, ok in zip(f.fit.names, f.fit.identifiable) if not ok) or "–",
             f"{f.seconds:.1f}" + (" (cached)" if f.cached else "")] for f in fits]  # fmt: skip
    header = ["family", "structure", "fitted (± standard error)", "phase RMS P1 / P2", "shape RMS A1 / A2",
              "A1 / A2 falls then rises", "not identifiable", "fit [s]"]  # fmt: skip
    met = [f for f in fits if f.meets_targets]
    if met:
        verdict = (f"**{', '.join(f.family.name for f in met)}** meet{'s' if len(met) == 1 else ''} both targets "
                   f"(phase RMS ≤ {TARGET_PHASE_RMS_DEG:g}°, shape RMS ≤ {100 * TARGET_SHAPE_RMS:g} %).")  # fmt: skip
    else:
        phase, shp = closest.fit.phase_rms_deg, closest.fit.shape_rms
        worst = 1 + int(np.argmax([max(phase[i] / TARGET_PHASE_RMS_DEG, shp[i] / TARGET_SHAPE_RMS) for i in (0, 1)]))
        verdict = (f"**No family meets both targets** (phase RMS ≤ {TARGET_PHASE_RMS_DEG:g}° and shape RMS ≤ "
                   f"{100 * TARGET_SHAPE_RMS:g} % per cell). The closest is **{closest.family.name}**: phases "
                   f"{_rms(phase)}, shapes {_rms(shp, percent=True)}, that is {closest.score:.2g}× the targets at worst "
                   f"(cell {worst}).")  # fmt: skip
    other = "deflection" if closest.family.transduction == "bridge" else "bridge"
    swapped = table4(closest.fit.robot, other)
    seed = _seed()
    swap_rms = [float(np.sqrt(np.mean((shape(swapped, c) - shape(seed, c)) ** 2))) for c in (1, 2)]
    parts = [
        "## What was the seed's model?",
        "The seed's Table 4 is the one output of its SolidWorks model we have; its geometry (Table 1) is garbled, "
        "and the joints, the cell's modelling and what it read as the signal are not stated. Each family below "
        "is a frame model with some robot-file keys free, fitted to the seed's Table 4 by `sail identify`'s "
        "machinery: phases directly, amplitudes by their shape (A / mean over Δ, free of the unknown signal unit; "
        "a 5 % shape error weighs as 1° of phase), 17 starts each. The bounds are `sail identify`'s defaults, "
        "chosen as physically plausible: lengths ½…2× the default robot's, joint stiffness 0.01…10⁷ N·m/rad "
        "(pin to bonded, fitted in log), the cell kept inside its link, crosstalk ±0.5 of the rated output. "
        f"Targets: phase RMS ≤ {TARGET_PHASE_RMS_DEG:g}° and shape RMS ≤ {100 * TARGET_SHAPE_RMS:g} % per cell.",
        markdown_table(header, rows),
        "![The families against the seed's Table 4](seed_model.png)",
        verdict + " " + _closest_reading(closest),
        "Bounds of the closest fit: " + _bounds(closest) + ".",
        "Large standard errors and *not identifiable* flags mean that Table 4 alone (8 Δ values, two phases and "
        "two shapes each) does not pin these parameters down: several structures match it about equally well, "
        "so a family's fit is evidence of what is *possible*, not a measurement of the seed's model.",
    ]
    if phases_only:
        best = phases_only[0]
        parts += [f"### Residuals: the best phases-only fit ({best.family.name})", _residual_table(best)]
    parts += [f"### Residuals: the closest fit with amplitude shape ({closest.family.name})",
              "Shape residuals are weighted: 1 unit is a 5 % error of A / mean.", _residual_table(closest),
              "### The amplitude shape depends on the reading",
              _reading_text(fits, closest, other, swap_rms)]  # fmt: skip
    parts += _corrections(result, main)
    return "\n\n".join(parts)


def _seed() -> np.ndarray:
    from ..paper.seed import seed_table4

    return seed_table4()


def _closest_reading(closest: FamilyFit) -> str:
    values = dict(zip(closest.fit.names, closest.fit.values))
    moment = values.get("loadcells.crosstalk_moment")
    if moment is None:
        return ""
    return (f"Its moment crosstalk ({moment:+.2f}) would be implausible in a commercial cell (datasheets quote "
            "a fraction of a percent) but not in the seed's surrogate: a SolidWorks cell is a plain block, and a "
            "displacement or strain probed on it mixes the shear with the local bending moment, which is what "
            "moment crosstalk models.")


def _reading_text(fits: tuple[FamilyFit, ...], closest: FamilyFit, other: str, swap_rms: list[float]) -> str:
    by_name = {f.family.name: f for f in fits}
    parts = []
    deflection, shear = by_name.get("springs, deflection"), by_name.get("springs, shear")
    if deflection is not None and shear is not None:
        parts.append(f"The same structure (a spring per joint, l3 and the cell position free) fitted under the "
                     f"far-face deflection reading reaches shapes {_rms(deflection.fit.shape_rms, True)}, under the "
                     f"shear (bridge) reading {_rms(shear.fit.shape_rms, True)}.")  # fmt: skip
    seed = _seed()
    parts.append(f"The seed's amplitudes fall, then rise with Δ (minima at Δ = {seed[np.argmin(seed[:, 1]), 0]:g}° "
                 f"and {seed[np.argmin(seed[:, 3]), 0]:g}°). The closest fit's robot, read instead by the "
                 f"{other} reading, has shapes {_rms((swap_rms[0], swap_rms[1]), True)} from the seed's: what the "
                 "seed read as its signal matters as much as its joints.")  # fmt: skip
    return " ".join(parts)


def _corrections(result: SeedModelResult, main: StudyResult) -> list[str]:
    ours = _pattern_words(main.table4)
    seed = result.seed_pattern
    drivers = result.drivers
    base = drivers[0]
    def spread(rows: list[tuple[str, float, float]], column: int) -> str:
        return f"{min(r[column] for r in rows):.1f}…{max(r[column] for r in rows):.1f}°"

    stiffness_rows = [base, *(r for r in drivers if "compliance" in r[0] or "link E" in r[0])]
    geometry_rows = [base, *(r for r in drivers if r[0].startswith(("l2", "l3", "cell position")))]
    delta_max = float(main.table4[-1, 0])
    driver_rows = [[label, f"{p1:.2f}", f"{p2:.2f}"] for label, p1, p2 in drivers]
    c = result.crosstalk
    l3, l2 = result.lengths
    force = main.protocol.force_N
    beyond = max(float(np.degrees(np.ptp(main.protocol.validation_poses(cell), axis=0)).max()) for cell in (1, 2))
    closest = dict(zip(result.closest.fit.names, result.closest.fit.values))
    closest_lengths = ", ".join(f"{k.split('.')[-1]} = {closest[k] if k in closest else get_parameter(result.closest.fit.robot, k):.3g} m"
                                for k in ("links.l3", "links.l2"))  # fmt: skip
    return [
        "### Three statements, corrected",
        "**1. The phase signs depend on the convention.** With s_i(φ) = T_i(φ + P_i)/A_i the seed's P1 is "
        f"{_sign(seed.signs[0])} and its P2 {_sign(seed.signs[1])}; the opposite convention (T_i(φ − P_i)) flips both, "
        "so agreeing signs are not evidence. The convention-free facts are that the two cells have opposite "
        f"signs (seed: {_yes(seed.opposite_signs)}) and that both grow in size with Δ (seed: "
        f"{_yes(seed.growing[0])} / {_yes(seed.growing[1])}). This study's {main.robot.joints.label} joints: {ours}.",
        f"**2. With bonded joints, geometry sets the size of the phases**, not the ratio of cell to link stiffness. "
        f"At Δ = {delta_max:g}°, bonded joints:",
        markdown_table(["variation", "P1 [deg]", "P2 [deg]"], driver_rows),
        f"A hundredfold change of the cell's compliance or of the links' modulus keeps P1 within "
        f"{spread(stiffness_rows, 1)} and P2 within {spread(stiffness_rows, 2)}; changes of 20 to 40 % in l2, l3 or "
        f"the cell position move P1 over {spread(geometry_rows, 1)} and P2 over {spread(geometry_rows, 2)}. (With "
        "spring joints, the joint stiffness does scale the phases.)",
        f"**3. Pin joints are exact only without crosstalk.** With pin joints and an axial crosstalk c = "
        f"{c.crosstalk:g} under the bridge reading, A1 varies by {100 * c.a1_spread:.1f} % of its mean over Δ, while "
        f"A1·(1 − c·cot Δ) varies by {c.a1_corrected_spread:.1e}: cell 1's axial force is N1 = −V1·cot Δ, in phase with "
        f"its shear, so its amplitude goes as 1/(1 − c·cot Δ) and its phase stays {c.p1_max_deg:.1g}°. N2 is not in "
        f"phase with V2: cell 2 gains a phase offset of {c.p2_range_deg[0]:.2f}…{c.p2_range_deg[1]:.2f}° and an "
        f"amplitude spread of {100 * c.a2_spread:.1f} %.",
        "### The lengths the seed's own numbers imply",
        f"Before compensation the pre-scaled curve k_i s_i misses the torque by F·l·|k_i/A_i·e^(jP_i) − 1|/√2 (RMS over φ). "
        f"With the seed's pre-scales ({SEED_PRESCALE[0]:g}, {SEED_PRESCALE[1]:g}), its regressors at the validation Δ "
        f"and its RMSEs before compensation ({SEED_RMSE['before']['t1']:g}, {SEED_RMSE['before']['t2']:g}), the torque "
        f"amplitudes are {force * l3:.3g} and {force * l2:.3g} N·m at {force:g} N: **l3 ≈ {l3:.2f} m and l2 ≈ {l2:.2f} m**. "
        "Caveats: it assumes the RMSEs are in N·m and pooled over poses and angles as ours are, and it evaluates the "
        f"regressors up to Δ = {beyond:g}°, beyond the seed's table. The closest family's lengths "
        f"({closest_lengths}) are not held to these, since Table 4 fixes shapes and phases only.",
    ]  # fmt: skip


def _sign(sign: int) -> str:
    return {1: "positive", -1: "negative"}.get(sign, "of mixed sign")


def _yes(flag: bool) -> str:
    return "yes" if flag else "no"


def _pattern_words(table: np.ndarray) -> str:
    from ..paper.seed_model import phase_pattern

    p = phase_pattern(table)
    return (f"P1 {_sign(p.signs[0])}, P2 {_sign(p.signs[1])}; opposite signs {_yes(p.opposite_signs)}, growing with Δ "
            f"{_yes(p.growing[0])} / {_yes(p.growing[1])}")  # fmt: skip


def seed_model_figure(result: SeedModelResult) -> Figure:
    """Each cell's phase and amplitude shape against Δ: the seed's points and every family's fit."""
    seed = _seed()
    fig = Figure(figsize=(10.0, 6.8), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    for cell in (1, 2):
        axes[0, cell - 1].plot(seed[:, 0], seed[:, 2 * cell], "ko", label="seed", zorder=3)
        axes[1, cell - 1].plot(seed[:, 0], shape(seed, cell), "ko", label="seed", zorder=3)
        for k, f in enumerate(result.fits):
            style = dict(color=f"C{k}", lw=2.2 if f is result.closest else 1.0, label=f.family.name)
            axes[0, cell - 1].plot(f.table[:, 0], f.table[:, 2 * cell], **style)
            if f.family.amplitude_weight > 0:
                axes[1, cell - 1].plot(f.table[:, 0], shape(f.table, cell), **style)
        axes[0, cell - 1].set(title=f"cell {cell}: phase P{cell}", ylabel="phase [deg]")
        axes[1, cell - 1].set(title=f"cell {cell}: amplitude A{cell} / mean", xlabel="Δ = θ1 − θ2 [deg]", ylabel="shape [-]")
    axes[0, 0].legend(fontsize=7)
    return fig


def write_seed_model(directory: Path, result: SeedModelResult, dpi: int) -> None:
    """``seed_model.json`` (every fit: parameters, SEs, bounds, metrics, residuals, its Table 4) and ``seed_model.png``."""
    fits = [{"family": f.family.name, "description": f.family.description, "transduction": f.family.transduction,
             "fixed": dict(f.family.fixed or {}), "amplitude_weight": f.family.amplitude_weight,
             "parameters": {n: {"value": float(v), "standard_error": _finite(s), "identifiable": bool(i), "bounds": list(b)}
                            for n, v, s, i, b in zip(f.fit.names, f.fit.values, f.fit.standard_errors,
                                                     f.fit.identifiable, f.fit.bounds)},
             "phase_rms_deg": list(f.fit.phase_rms_deg), "shape_rms": [None if math.isnan(v) else v for v in f.fit.shape_rms],
             "meets_targets": f.meets_targets, "residual_columns": list(f.fit.residual_columns),
             "residuals": f.fit.residuals.tolist(), "table4": f.table.tolist(), "seconds": f.seconds,
             "cached": f.cached}
            for f in result.fits]  # fmt: skip
    c = result.crosstalk
    write_json(directory / "seed_model.json", {
        "targets": {"phase_rms_deg": TARGET_PHASE_RMS_DEG, "shape_rms": TARGET_SHAPE_RMS},
        "fits": fits, "closest": result.closest.family.name,
        "bonded_phase_drivers": [{"variation": label, "P1_deg": p1, "P2_deg": p2} for label, p1, p2 in result.drivers],
        "pin_crosstalk": {"crosstalk_axial": c.crosstalk, "a1_spread": c.a1_spread, "a1_corrected_spread": c.a1_corrected_spread,
                          "p1_max_deg": c.p1_max_deg, "p2_range_deg": list(c.p2_range_deg), "a2_spread": c.a2_spread},
        "implied_lengths_m": {"l3": result.lengths[0], "l2": result.lengths[1]},
    })  # fmt: skip
    write_figure(directory / "seed_model.png", seed_model_figure(result), dpi=dpi)
