"""The ``sail`` command line.

Errors are one line: exit code 2 for usage errors (click's own), 1 for data
errors (any :class:`sailforce.SailError` or file-system failure).
"""

from __future__ import annotations

import click

from .. import __version__
from ..errors import SailError


class DataError(click.ClickException):
    """Bad data rather than bad usage: exit code 1."""

    exit_code = 1


class SailGroup(click.Group):
    """A group that turns library errors into one-line CLI errors."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except SailError as exc:
            raise DataError(str(exc)) from None
        except OSError as exc:
            name = f"{exc.filename}: " if exc.filename else ""
            raise DataError(f"{name}{exc.strerror or exc}") from None


CONTEXT_SETTINGS = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


@click.group(cls=SailGroup, context_settings=CONTEXT_SETTINGS)
@click.version_option(__version__, "--version", prog_name="sail")
def cli() -> None:
    """SAIL: end-effector force from two link-integrated load cells.

    Angles on the command line are in degrees, counter-clockwise from +x;
    everything else is SI.
    """


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="sail")


from . import calibrate_cmd, demo_cmd, estimate_cmd, fitpoly_cmd, reproduce_cmd, robot_cmd, simulate_cmd, statics_cmd, stress_cmd  # noqa: E402,F401  (registers commands)
