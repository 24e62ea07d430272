"""``report.md`` and its self-contained HTML twin: every result beside the seed's published numbers."""

from __future__ import annotations

import base64
import math
import re
from pathlib import Path

import numpy as np
from markdown_it import MarkdownIt

from .._version import __version__
from ..io.files import atomic_writer
from ..kinematics import SINGULAR_SIN_DELTA
from ..materials import CARBON_STEEL, SEED_TABLE2_SHEAR_MODULUS
from ..paper.seed_model import SeedModelResult, phase_pattern
from ..paper.study import ModelId, Protocol, StudyResult, span_deg
from ..sensing.polynomial import fit_polynomial
from .labels import links_label, markdown_table, model_label
from .results import SEED_PRESCALE, SEED_REGRESSORS, SEED_RMSE, seed_table4

#: How far past the fitted Delta range [deg] a validation pose must lie to count as extrapolated.
RANGE_SLACK_DEG = 1e-9


def errata(protocol: Protocol) -> list[str]:
    """The seed's errors the report lists, each number computed here rather than typed (docs/errata.md)."""
    seed = seed_table4()
    a2_order = len(SEED_REGRESSORS["amplitude_2"]) - 1
    a2 = fit_polynomial(seed[:, 0], seed[:, 3], a2_order)
    singular_deg = math.degrees(math.asin(SINGULAR_SIN_DELTA))
    pose = protocol.stress_pose_deg
    return [
        "**Eq. 10 is wrong**: the printed matrix is the transpose of the true inverse of Jᵀ; Eqs. 11 and 12 "
        "inherit the error. sailforce uses (Jᵀ)⁻¹ = [[−l2 cos θ2, l3 cos θ1], [−l2 sin θ2, l3 sin θ1]] / "
        "(l2 l3 sin(θ1 − θ2)).",
        "**Eq. 13 (polar form) is garbled**: |F| = hypot(Fx, Fy), φ = atan2(Fy, Fx) are used instead.",
        "**The estimate is singular** where sin(θ1 − θ2) = 0; the force error grows as 1/|sin Δ|. Poses with "
        f"|sin Δ| < sin {singular_deg:.3g}° are refused or flagged.",
        "**Table 1 is garbled** (its cells repeat Table 2), so the paper gives no link lengths or sections; "
        "the default robot is our assumption.",
        f"**Table 2's shear modulus** ({SEED_TABLE2_SHEAR_MODULUS / 1e9:.0f} GPa) is inconsistent with E/2(1 + ν) = "
        f"{CARBON_STEEL.G / 1e9:.0f} GPa; G is derived from E and ν.",
        f"**A2 does not follow the stated rule**: its published order-{a2_order} fit passes plain R² > "
        f"{a2.threshold:g} ({a2.r2:.5f}) but not adjusted R² ({a2.adj_r2:.5f}), which picks a higher order. "
        "`--criterion r2` reproduces it.",
        "**The RMSEs have no unit in the paper**; they are torque errors of curves pre-scaled by "
        f"{SEED_PRESCALE[0]:g} and {SEED_PRESCALE[1]:g}.",
        f"**The Fig. 4 pose is not given**; this study uses θ1 = {pose[0]:g}°, θ2 = {pose[1]:g}°.",
    ]


def _g(value: float, digits: int = 4) -> str:
    return f"{value:.{digits}g}"


def _poly(coefficients) -> str:
    order = len(coefficients) - 1
    terms = [f"{c:+.4g}" + (f"·Δ^{order - k}" if order - k > 1 else "·Δ" if order - k == 1 else "")
             for k, c in enumerate(coefficients)]  # fmt: skip
    return " ".join(terms)


def _table4_section(result: StudyResult, seed: np.ndarray) -> str:
    rows = [[f"{r[0]:g}", _g(r[1], 6), _g(s[1], 6), f"{r[2]:.3f}", f"{s[2]:.3f}", _g(r[3], 6), _g(s[3], 6),
             f"{r[4]:.3f}", f"{s[4]:.3f}"] for r, s in zip(result.table4, seed)]  # fmt: skip
    header = ["Δ [deg]", "A1 ours", "A1 seed", "P1 ours [deg]", "P1 seed", "A2 ours", "A2 seed", "P2 ours [deg]", "P2 seed"]
    regs = [[name, str(fit.order), "yes" if fit.passed else "**no**", f"{fit.r2:.6f}", f"{fit.adj_r2:.6f}",
             _poly(fit.coefficients), _poly(SEED_REGRESSORS[name])] for name, fit in result.regressors.items()]  # fmt: skip
    criterion = "adjusted R²" if result.criterion == "adj-r2" else "plain R²"
    return "\n\n".join([
        "## Table 4: amplitude and phase of each load cell",
        f"Least-squares sinusoid fits of each load-cell curve over all {len(result.protocol.phi_deg)} force angles, "
        "against the torque "
        "predicted by Eq. 7. **Sign convention**: s_i(φ) = T_i(φ + P_i)/A_i, so A_i is torque per signal unit "
        "and a positive P_i means the load-cell curve peaks P_i earlier in φ than the predicted torque. The "
        "seed does not state its convention; its amplitudes are in N·m per its (unstated) deflection unit, "
        f"ours in N·m per {'m' if result.transduction == 'deflection' else 'mV/V'}, so compare amplitudes by "
        "their shape (normalised in the figure), phases directly.",
        markdown_table(header, rows),
        "![Table 4 as curves](table4.png)",
        _amplitude_shape(result, seed),
        f"### Regressors (smallest order with {criterion} > {result.threshold:g})",
        markdown_table(["column", "order", "passed", "R²", "adj. R²", "ours (Δ in deg)", "seed"], regs),
    ])  # fmt: skip


def _amplitude_shape(result: StudyResult, seed: np.ndarray) -> str:
    """Where each amplitude column is smallest, ours against the seed's: the shapes differ most there."""
    parts = []
    for i, column in ((1, 1), (2, 3)):
        ours, theirs = result.table4[:, column], seed[:, column]
        parts.append(f"A{i} is smallest at Δ = {result.table4[np.argmin(ours), 0]:g}° here and at "
                     f"Δ = {seed[np.argmin(theirs), 0]:g}° in the seed; it spans {np.ptp(ours) / np.mean(ours):.0%} "
                     f"of its mean here and {np.ptp(theirs) / np.mean(theirs):.0%} in the seed")  # fmt: skip
    pattern = phase_pattern(result.table4)
    phases = ("The phases share the seed's convention-free pattern: the two cells have opposite signs and both "
              "grow with Δ." if pattern.convention_free_match else "The phases do not share the seed's "
              "convention-free pattern (opposite signs, both growing with Δ).")  # fmt: skip
    return ("**Shapes.** " + "; ".join(parts) + ". " + phases + " Whether the amplitudes rise again towards "
            "small Δ, as the seed's do, depends on what is read as the signal and on how the cell is modelled: "
            "see *What was the seed's model?* (`sail reproduce --seed-model`, the default).")


def _rmse_section(result: StudyResult) -> str:
    amp = result.torque_amplitude
    protocol = result.protocol
    rel_b, rel_a = result.rmse_before.relative(amp), result.rmse_after.relative(amp)
    rel_e = result.rmse_after_estimator.relative(amp)
    rows = [
        ["before (k × load)", _g(result.rmse_before.t1), _g(result.rmse_before.t2), _g(result.rmse_before.mean),
         f"{100 * rel_b.t1:.2f} / {100 * rel_b.t2:.2f}", f"{SEED_RMSE['before']['t1']} / {SEED_RMSE['before']['t2']}"],
        ["after, the seed's curve shift", _g(result.rmse_after.t1), _g(result.rmse_after.t2), _g(result.rmse_after.mean),
         f"{100 * rel_a.t1:.3f} / {100 * rel_a.t2:.3f}", f"{SEED_RMSE['after']['t1']} / {SEED_RMSE['after']['t2']}"],
        ["after, run-time estimator (2×2 solve)", _g(result.rmse_after_estimator.t1), _g(result.rmse_after_estimator.t2),
         _g(result.rmse_after_estimator.mean), f"{100 * rel_e.t1:.3f} / {100 * rel_e.t2:.3f}", "–"],
    ]  # fmt: skip
    per_pose = [result.rmse_after_per_pose(i) for i in range(2)]
    delta_v = [np.degrees(result.validation[i].delta) for i in range(2)]
    low, high = np.degrees(result.compensator.delta_range)
    outside = [np.flatnonzero((d < low - RANGE_SLACK_DEG) | (d > high + RANGE_SLACK_DEG)) for d in delta_v]
    extrapolation = "; ".join(
        f"cell {i + 1}: {_g(per_pose[i][o].max(), 3)} N·m at Δ = {', '.join(f'{d:g}°' for d in delta_v[i][o])} "
        f"against a median of {_g(float(np.median(np.delete(per_pose[i], o))), 3)} N·m inside"
        for i, o in enumerate(outside) if o.size
    )  # fmt: skip
    return "\n\n".join([
        "## Validation: RMSE before and after compensation",
        f"T1 on grid 1 ({protocol.describe_grid(1, validation=True)}), T2 on grid 2 "
        f"({protocol.describe_grid(2, validation=True)}), pooled over poses and the {len(protocol.phi_deg)} force "
        f"angles. The torque amplitudes are F·l3 = {amp[0]:g} N·m and F·l2 = {amp[1]:g} N·m.",
        markdown_table(["", "T1 [N·m]", "T2 [N·m]", "mean [N·m]", "relative T1 / T2 [%]", "seed T1 / T2"], rows),
        "![Compensated validation curves (Fig. 6)](fig6_compensated.png)",
        f"**Extrapolation.** Validation poses beyond the fitted range {low:g}…{high:g}°, where the polynomials "
        f"extrapolate: {extrapolation or 'none lies outside'}.",
    ])


def _beyond_section(result: StudyResult) -> str:
    matrix = result.matrix_compensator
    protocol = result.protocol
    force_rows = [[model_label(model, protocol), _g(value, 3), f"{100 * value / protocol.force_N:.3f}"]
                  for model, value in result.force_rmse.items()]  # fmt: skip
    ws = result.workspace
    delta_deg = np.degrees(ws.delta)
    low, high = np.degrees(result.compensator.delta_range)
    inside = (delta_deg >= low - RANGE_SLACK_DEG) & (delta_deg <= high + RANGE_SLACK_DEG)
    ws_rows = [[model_label(model, protocol), f"{100 * e[inside].max():.3g}", f"{100 * e[~inside].max():.3g}",
                f"{100 * e.max():.3g}"] for model, e in ws.relative_error.items()]  # fmt: skip
    fitted = f"{low:g}…{high:g}°"
    return "\n\n".join([
        "## Beyond the seed",
        "The seed compensates each load cell by a gain and a phase, fitted from one sweep per cell. Here the "
        "**matrix compensator** fits the whole 2×2 sensing map on all sweep data of both load cells at once: "
        "s = C(Δ) T, each signal a Δ-dependent mix of both predicted torques T = Jᵀ F, with C(Δ) as Chebyshev "
        "series in Δ whose order is chosen by leave-one-Δ-out "
        f"cross-validation of the force error: order {matrix.order} was chosen (CV force RMSE by order: "
        + ", ".join(f"{v:.3g}" for v in matrix.cv_rmse) + " N). All three estimators solve the same 2×2 system at run time.",
        "### Force-vector error on the validation grids",
        markdown_table(["model", "RMSE ‖F̂ − F‖ [N]", f"% of {protocol.force_N:g} N"], force_rows),
        f"### Over the whole workspace, Δ = {span_deg(protocol.workspace_delta_deg)}",
        markdown_table(["model", f"max inside {fitted} [%]", "max outside [%]", "max [%]"], ws_rows),
        "![Force error over the workspace](workspace.png)",
        f"Both fitted compensators are only as good as the Δ range they were calibrated on: outside {fitted} they "
        "extrapolate, and the error grows fast. The last model, the same matrix compensator fitted on a sweep "
        f"that spans the whole workspace (Δ = {span_deg(protocol.wide_calibration_delta_deg, step=True)}), shows "
        "that the remedy is to calibrate over the range the robot uses.",
    ])  # fmt: skip


def _comparison_section(main: StudyResult, other: StudyResult) -> str:
    def summary(r: StudyResult) -> list[str]:
        t = r.table4
        amp_var = [np.ptp(t[:, c]) / np.mean(t[:, c]) for c in (1, 3)]
        return [
            r.robot.joints.label,
            f"{t[:, 2].min():.3g} … {t[:, 2].max():.3g}",
            f"{t[:, 4].min():.3g} … {t[:, 4].max():.3g}",
            f"{100 * amp_var[0]:.3g} / {100 * amp_var[1]:.3g}",
            f"{_g(r.rmse_before.mean, 3)} → {_g(r.rmse_after.mean, 3)}",
            " / ".join(_g(r.force_rmse[m], 3) for m in (ModelId.UNCOMPENSATED, ModelId.SEED, ModelId.MATRIX)),
            f"{_g(r.delta_only_discrepancy['amplitude_relative'], 2)} / {_g(r.delta_only_discrepancy['phase_deg'], 2)}",
        ]

    seed_t = seed_table4()
    seed_row = ["seed (SolidWorks)", f"{seed_t[:, 2].min():.3g} … {seed_t[:, 2].max():.3g}",
                f"{seed_t[:, 4].min():.3g} … {seed_t[:, 4].max():.3g}",
                f"{100 * np.ptp(seed_t[:, 1]) / seed_t[:, 1].mean():.3g} / {100 * np.ptp(seed_t[:, 3]) / seed_t[:, 3].mean():.3g}",
                f"{SEED_RMSE['before']['mean']} → {SEED_RMSE['after']['mean']}", "–", "–"]  # fmt: skip
    header = ["joints", "P1 range [deg]", "P2 range [deg]", "A1 / A2 spread [% of mean]", "mean RMSE before → after [N·m]",
              "force RMSE uncomp. / seed / matrix [N]", "Δ-only check: ΔA rel. / ΔP [deg]"]  # fmt: skip
    return "\n\n".join([
        "## How the joint model drives the deviations",
        markdown_table(header, [summary(main), summary(other), seed_row]),
        "**With ideal pin joints the linkage is statically determinate**: link l4 is a two-force member, each "
        "driven link carries the constant shear T_i/l_i, and, without crosstalk, the load-cell signal is exactly "
        "proportional to the predicted torque. Table 4 is then constant (P = 0 to rounding) and there is nothing to "
        "compensate. "
        "**Joints that carry moment** (SolidWorks' default bonded contact, or stiff bearings) close the "
        "parallelogram into a statically indeterminate frame that shares load through bending, and amplitude "
        "and phase deviations appear that vary with Δ. "
        + ("On this robot with bonded joints the phases share the seed's convention-free pattern (opposite signs, "
           "both growing with Δ), consistent with docs/errata.md's hypothesis that its SolidWorks model had bonded "
           "or otherwise moment-carrying joints. " if phase_pattern(main.table4).convention_free_match else "")
        + "With bonded joints the size of the phases is set by the geometry (l2/l3, the cell position), not by "
        "the ratio of cell to link stiffness; with spring joints the joint stiffness scales them. The seed's "
        "Table 1 is garbled, so its geometry is unknown: *What was the seed's model?* fits it.",
        "**The Δ-only dependence.** With locked motors and no gravity, changing θ2 at fixed Δ rotates the whole "
        "structure rigidly, so the sensing map is M0(Δ) R(−θ2). The last column compares both cells' amplitude "
        f"and phase from sweep 1 ({main.protocol.describe_grid(1)}) and sweep 2 ({main.protocol.describe_grid(2)}) "
        "at equal Δ: they agree to rounding, which is why one table in Δ serves every pose.",
    ])  # fmt: skip


def report_markdown(main: StudyResult, comparison: StudyResult | None, study_seconds: float,
                    seed_model: SeedModelResult | None = None, solid: str | None = None) -> str:
    """The whole report as Markdown; figures are referenced by file name in the same directory."""
    seed = seed_table4()
    k = main.prescale
    robot = main.robot
    protocol = main.protocol
    sweep_runs, validation_runs = protocol.runs()
    parts = [
        "# SAIL: the seed paper's virtual study, reproduced",
        f"sailforce {__version__} · joints **{robot.joints.label}** · transduction **{main.transduction}** · "
        f"criterion **{main.criterion} > {main.threshold:g}** · study computed in {study_seconds:.2f} s "
        f"(the protocol is {sweep_runs} + {validation_runs} analyses, which the seed ran in SolidWorks).",
        f"Robot: l1 = {robot.arm.l1:g} m, l2 = {robot.arm.l2:g} m, l3 = {robot.arm.l3:g} m, l4 = {robot.arm.l4:g} m; "
        f"{links_label(robot)}; load cell EI = {robot.loadcell.bending_rigidity:.4g} N·m², "
        f"{robot.loadcell.capacity_N:g} N capacity; motors {robot.motors.model}.",
        "## Errata in the seed paper",
        "\n".join(f"- {e}" for e in errata(protocol)),
        "## Stress patterns (Fig. 4)",
        f"{protocol.force_N:g} N at φ = {span_deg(protocol.stress_phi_deg, step=True)}, at θ1 = "
        f"{protocol.stress_pose_deg[0]:g}°, θ2 = {protocol.stress_pose_deg[1]:g}°. As in the seed, the driven links "
        "l1 and l2 are always in "
        "bending; l3 and l4 change between bending, tension and compression with φ.",
        "![Stress patterns](fig4_stress.png)",
        "## Sweeps 1 and 2 (Fig. 5)",
        f"Each load-cell curve is scaled by one least-squares constant per cell, as the seed pre-scaled its "
        f"curves by {SEED_PRESCALE[0]:g} and {SEED_PRESCALE[1]:g}: k1 = {k[0]:.6g}, k2 = {k[1]:.6g} N·m per "
        f"{'m' if main.transduction == 'deflection' else 'mV/V'}.",
        "![Sweeps (Fig. 5)](fig5_sweeps.png)",
        _table4_section(main, seed),
        _rmse_section(main),
        _beyond_section(main),
    ]  # fmt: skip
    if comparison is not None:
        parts.append(_comparison_section(main, comparison))
        parts.append(f"The {comparison.robot.joints.model}-joint pass has its own figures, `table4.csv` and "
                     f"`results.json` in `{comparison.robot.joints.model}/`.")  # fmt: skip
    if seed_model is not None:
        from .seed_model import seed_model_section

        parts.append(seed_model_section(seed_model, main))
    if solid is not None:
        parts.append(solid)
    parts.append("## Files\n\n- `table4.csv`, `results.json`: the numbers above.\n"
                 "- `fig4_stress.png`, `fig5_sweeps.png`, `fig6_compensated.png`, `table4.png`, `workspace.png`."
                 + ("\n- `seed_model.json`, `seed_model.png`: the fits to the seed's Table 4." if seed_model else ""))  # fmt: skip
    return "\n\n".join(parts) + "\n"


HTML_STYLE = """body{font-family:system-ui,sans-serif;max-width:72rem;margin:2rem auto;padding:0 1rem;line-height:1.45}
table{border-collapse:collapse;margin:1rem 0;font-size:.9rem}td,th{border:1px solid #ccc;padding:.25rem .5rem;text-align:right}
th{background:#f3f3f3}img{max-width:100%}code{background:#f3f3f3;padding:0 .2rem}"""


def markdown_to_html(markdown: str, directory: Path, title: str) -> str:
    """Render ``markdown`` to one HTML page, embedding each referenced image from ``directory`` as a data URI."""
    body = MarkdownIt("commonmark").enable("table").render(markdown)

    def embed(match: re.Match) -> str:
        path = directory / match.group(1)
        if not path.is_file():
            return match.group(0)
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        return f'src="data:image/png;base64,{data}"'

    body = re.sub(r'src="([^":]+\.png)"', embed, body)
    return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title>"
            f"<style>{HTML_STYLE}</style></head><body>\n{body}</body></html>\n")  # fmt: skip


def write_report(directory: Path, main: StudyResult, comparison: StudyResult | None, study_seconds: float,
                 seed_model: SeedModelResult | None = None, solid: str | None = None) -> None:
    """Write ``report.md`` and the self-contained ``report.html`` into ``directory``; ``solid``: that section's Markdown."""
    markdown = report_markdown(main, comparison, study_seconds, seed_model, solid)
    with atomic_writer(directory / "report.md") as stream:
        stream.write(markdown)
    with atomic_writer(directory / "report.html") as stream:
        stream.write(markdown_to_html(markdown, directory, "SAIL: the seed's study, reproduced"))

