"""The ``sail`` command line.

Errors are one line: exit code 2 for usage errors (click's own), 1 for data
errors (any :class:`sailforce.SailError` or file-system failure).
"""

from __future__ import annotations

import importlib

import click

from .. import __version__
from ..errors import SailError


class DataError(click.ClickException):
    """Bad data rather than bad usage: exit code 1."""

    exit_code = 1


#: Command name -> the module that defines it.  Modules load on first use, so
#: ``sail estimate`` does not pay for the plotting and FEM imports.
_COMMAND_MODULES = {
    "calibrate": "calibrate_cmd",
    "demo": "demo_cmd",
    "estimate": "estimate_cmd",
    "export-c": "export_cmd",
    "fit-poly": "fitpoly_cmd",
    "reproduce": "reproduce_cmd",
    "robot": "robot_cmd",
    "simulate": "simulate_cmd",
    "statics": "statics_cmd",
    "stress": "stress_cmd",
    "tare": "calibrate_cmd",
}


class SailGroup(click.Group):
    """A group that loads its commands lazily and turns library errors into one-line CLI errors."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(_COMMAND_MODULES) | set(self.commands))

    def get_command(self, ctx: click.Context, name: str):
        if name not in self.commands and name in _COMMAND_MODULES:
            importlib.import_module(f"{__name__}.{_COMMAND_MODULES[name]}")  # registers the command
        return self.commands.get(name)

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

