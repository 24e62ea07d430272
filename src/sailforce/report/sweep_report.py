"""A design sweep's outputs: the table (CSV and Parquet), the Pareto figure and the report's section."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
from matplotlib.figure import Figure

from ..design.sweep import SweepResult
from ..io.files import atomic_writer, write_figure
from .labels import markdown_table

#: Rows of the ranking shown in the report (the table holds them all).
REPORT_ROWS = 15


def sweep_table(result: SweepResult) -> pa.Table:
    """One row per variant, in variant order."""
    return pa.table({name: pa.array(values.tolist()) for name, values in result.columns.items()})


def pareto_figure(result: SweepResult) -> Figure:
    """Resolution against overload, coloured by the first frequency; the Pareto set ringed; and resolution
    against the first frequency."""
    c = result.columns
    ok = c["status"] == "ok"
    fig = Figure(figsize=(11.0, 4.6), layout="constrained")
    left, right = fig.subplots(1, 2)
    scatter = left.scatter(c["resolution_N"][ok], c["overload_N"][ok], c=c["first_frequency_Hz"][ok], s=18,
                           cmap="viridis")  # fmt: skip
    for ax, y in ((left, "overload_N"), (right, "first_frequency_Hz")):
        front = ok & result.pareto
        ax.scatter(c["resolution_N"][front], c[y][front], s=70, facecolors="none", edgecolors="C3", linewidths=1.5,
                   label=f"Pareto set ({front.sum()})")  # fmt: skip
        best = result.ranked()[:1]
        ax.scatter(c["resolution_N"][best], c[y][best], marker="*", s=180, color="C1", label="rank 1", zorder=3)
        ax.set_xscale("log")
        ax.legend(loc="best", fontsize="small")
    right.scatter(c["resolution_N"][ok], c["first_frequency_Hz"][ok], s=18, color="0.4")
    required = result.requirements.required_force_N
    left.axhline(required, color="C1", ls="--", lw=1)
    left.set(xlabel="resolution, 1σ worst over the workspace [N]", ylabel="overload, worst [N]",
             title=f"{len(result)} variants (dashed: required {required:g} N)")  # fmt: skip
    right.set(xlabel="resolution, 1σ worst over the workspace [N]", ylabel="first natural frequency, lowest [Hz]",
              title="smaller noise, larger overload and frequency are better")  # fmt: skip
    fig.colorbar(scatter, ax=left, label="first frequency, lowest [Hz]")
    return fig


def _row(result: SweepResult, i: int, names: list[str]) -> list[str]:
    c = result.columns
    cells = [c[name][i] if isinstance(c[name][i], str) else f"{c[name][i]:.4g}" for name in names]
    return [str(c["rank"][i] or "–"), *cells, f"{c['resolution_N'][i]:.3g}", f"{c['overload_N'][i]:.4g}",
            c["overload_limit"][i], f"{c['first_frequency_Hz'][i]:.3g}", "yes" if c["pareto"][i] else ""]  # fmt: skip


def sweep_markdown(result: SweepResult) -> str:
    """The report's section: what was swept, the ranking, the Pareto set, the failures."""
    c = result.columns
    names = [axis.name for axis in result.axes] + (["price"] if "price" in c else [])
    header = ["rank", *names, "resolution [N]", "overload [N]", "limited by", "first frequency [Hz]", "Pareto"]
    ranked = result.ranked()
    front = [i for i in np.flatnonzero(result.pareto) if c["rank"][i] == 0]
    failed = np.flatnonzero(c["status"] != "ok")
    req = result.requirements
    parts = [
        "## Sweep",
        f"{len(result)} variants ({' × '.join(f'{len(a.labels)} {a.name}' for a in result.axes)}), each mapped over its "
        f"own workspace grid, computed in {result.seconds:.1f} s. A variant is **ranked** when its overload is at "
        f"least {req.required_force_N:g} N and its first frequency at least {req.min_frequency_Hz:g} Hz everywhere, "
        "best resolution first (then price, first frequency, overload); it is on the **Pareto set** when no other "
        "variant is at least as good in resolution, overload and first frequency and better in one.",
        "![Pareto](pareto.png)",
    ]
    if len(ranked):
        parts.append(markdown_table(header, [_row(result, i, names) for i in ranked[:REPORT_ROWS]]))
        if len(ranked) > REPORT_ROWS:
            parts.append(f"…and {len(ranked) - REPORT_ROWS} more ranked variants in `sweep.csv`.")
    else:
        parts.append("**No variant meets the requirements.**")
    if front:
        parts += ["Pareto-optimal variants that miss the requirements:",
                  markdown_table(header, [_row(result, i, names) for i in front[:REPORT_ROWS]])]  # fmt: skip
    if len(failed):
        parts.append(f"**{len(failed)} variant(s) could not be mapped** (their rows in `sweep.csv` say why): "
                     + "; ".join(f"variant {i}: {c['status'][i]}" for i in failed[:5]))  # fmt: skip
    parts.append("Files: `sweep.csv` and `sweep.parquet` (one row per variant), `pareto.png`.")
    return "\n\n".join(parts)


#: Every file :func:`write_sweep` writes.
SWEEP_OUTPUTS = ("sweep.csv", "sweep.parquet", "pareto.png")


def write_sweep(directory: Path, result: SweepResult, dpi: int) -> str:
    """``sweep.csv``, ``sweep.parquet`` and ``pareto.png`` into ``directory``; returns the report's section."""
    directory.mkdir(parents=True, exist_ok=True)
    table = sweep_table(result)
    with atomic_writer(directory / "sweep.csv", "wb") as stream:
        pa_csv.write_csv(table, stream)
    with atomic_writer(directory / "sweep.parquet", "wb") as stream:
        pq.write_table(table, stream)
    write_figure(directory / "pareto.png", pareto_figure(result), dpi=dpi)
    return sweep_markdown(result)
