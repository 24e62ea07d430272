"""``sail fit-poly``: polynomial regressors of each column of a table against its first column."""

from __future__ import annotations

import json
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from ..io.files import read_numeric_csv
from ..sensing.polynomial import CRITERIA, DEFAULT_CRITERION, DEFAULT_THRESHOLD, select_order
from . import cli


@cli.command("fit-poly")
@click.argument("table_path", metavar="TABLE.csv", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--seed-table4", is_flag=True, help="Fit the seed's Table 4, which ships with sailforce, instead of TABLE.csv.")
@click.option("--criterion", type=click.Choice(CRITERIA), default=DEFAULT_CRITERION, show_default=True,
              help="Adjusted R² (the seed's stated rule) or plain R².")
@click.option("--threshold", type=click.FloatRange(0.0, 1.0, min_open=True, max_open=True),
              default=DEFAULT_THRESHOLD, show_default=True, help="The smallest order whose criterion exceeds this wins.")
@click.option("--max-order", type=click.IntRange(0), default=None,
              help="Highest order tried. Default: rows - 2, the highest at which adjusted R² is defined.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON keyed by column: order, coefficients, r2, adj_r2.")
def fit_poly_command(table_path, seed_table4, criterion, threshold, max_order, as_json):
    """Fit each column of TABLE.csv against the first, as the seed fitted Table 4.

    TABLE.csv has a header row and numbers only.  For each column after the
    first, the lowest polynomial order whose criterion exceeds the threshold
    is chosen; coefficients are printed highest power first.  The seed's own
    Table 4 ships with sailforce: `sail fit-poly --seed-table4`.
    """
    if (table_path is None) == (not seed_table4):
        raise click.UsageError("give TABLE.csv or --seed-table4 (one of them)")
    if seed_table4:
        from importlib.resources import files

        table_path = Path(str(files("sailforce") / "data" / "seed_table4.csv"))
    names, table = read_numeric_csv(table_path, min_columns=2)
    fits = {
        name: select_order(table[:, 0], table[:, k], criterion=criterion, threshold=threshold, max_order=max_order)
        for k, name in enumerate(names[1:], start=1)
    }
    if as_json:
        payload = {name: fit.as_dict() for name, fit in fits.items()}
        click.echo(json.dumps(payload, indent=2))
        return
    console = Console()
    label = "adjusted R²" if criterion == "adj-r2" else "R²"
    out = Table(title=f"{table_path}: smallest order with {label} > {threshold:g}, against {names[0]}")
    for head in ("column", "order", "R²", "adj. R²", "coefficients (highest power first)"):
        out.add_column(head, justify="left" if head.startswith("coef") or head == "column" else "right")
    for name, fit in fits.items():
        order = str(fit.order) if fit.passed else f"{fit.order} (criterion not met)"
        out.add_row(name, order, f"{fit.r2:.6f}", f"{fit.adj_r2:.6f}", "  ".join(f"{c:.4g}" for c in fit.coefficients))
    console.print(out)
    failed = [name for name, fit in fits.items() if not fit.passed]
    if failed:
        Console(stderr=True).print(f"[bold yellow]warning:[/bold yellow] no order up to {fits[failed[0]].order} "
                                   f"met the criterion for {', '.join(failed)}")  # fmt: skip
