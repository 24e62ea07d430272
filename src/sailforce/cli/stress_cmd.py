"""``sail stress``: the arm coloured by von Mises stress (the seed's Fig. 4)."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np

from ..fem.model import MEMBERS
from ..fem.response import member_stresses, simulate
from ..io.files import atomic_writer, check_output
from ..sweep import check_not_singular
from . import cli
from ._options import FINITE, joints_option, load_robot, robot_option, spec


@cli.command("stress")
@robot_option
@joints_option
@click.option("--theta1-deg", type=FINITE, default=75.0, show_default=True, help="Angle of l1 [deg].")
@click.option("--theta2-deg", type=FINITE, default=0.0, show_default=True, help="Angle of l2 [deg].")
@click.option("--force-N", "force_n", type=FINITE, default=10.0, show_default=True, help="Force at A [N].")
@click.option("--phi-deg", default="0:315:45", show_default=True, callback=spec("phi"), help="SPEC of force angles, one panel each.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Image file; the extension picks the format (.png, .pdf, .svg, ...); none means .png.")
def stress_command(robot_path, joints, theta1_deg, theta2_deg, force_n, phi_deg, output):
    """Draw the arm coloured by von Mises stress, one panel per force angle.

    Also prints the most stressed member and the smallest yield safety
    factor over all panels.  The seed does not say which pose its Fig. 4
    used; the default here is theta1 = 75 deg, theta2 = 0.
    """
    from ..report.stress_figure import MAX_PANELS, stress_figure

    if phi_deg.size > MAX_PANELS:
        raise click.BadParameter(f"{phi_deg.size} force angles, one panel each: at most {MAX_PANELS}", param_hint="--phi-deg")
    output = output if output.suffix else output.with_suffix(".png")
    image_format = _image_format(output)
    check_output(output, {"the --robot file": robot_path})
    robot = load_robot(robot_path, joints)
    theta1, theta2 = math.radians(theta1_deg), math.radians(theta2_deg)
    check_not_singular(theta1, theta2)
    response = simulate(robot, theta1, theta2)
    phi = np.radians(phi_deg)
    fig = stress_figure(response, phi, force_n)
    with atomic_writer(output, "wb") as stream:
        fig.savefig(stream, format=image_format, dpi=150)
    stresses = member_stresses(response, force_n * np.cos(phi), force_n * np.sin(phi))
    worst = np.unravel_index(np.argmax(stresses.von_mises), stresses.von_mises.shape)
    safety = float(stresses.safety_factor.min())
    click.echo(
        f"wrote {output}: peak von Mises {stresses.von_mises[worst] / 1e6:.3g} MPa in {MEMBERS[worst[1]][0]} "
        f"at phi = {phi_deg[worst[0]]:g} deg; smallest yield safety factor {safety:.3g}"
    )


def _image_format(output: Path) -> str:
    from matplotlib.figure import Figure

    formats = Figure().canvas.get_supported_filetypes()
    suffix = output.suffix.lower().lstrip(".")
    if suffix not in formats:
        raise click.BadParameter(f"{output}: unknown image format .{suffix}; use one of "
                                 f"{', '.join('.' + f for f in sorted(formats))}", param_hint="-o")  # fmt: skip
    return suffix
