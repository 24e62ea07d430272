"""The ``sail`` command line.

Errors are one line.  Exit codes: 0 done; 1 data errors (any
:class:`sailforce.SailError`, a file-system failure, too little memory); 2
usage errors (click's own); 70 an internal error, a bug in sailforce (one
line too; ``SAIL_TRACEBACK=1`` shows the traceback); 130 interrupted by
Ctrl-C and 143 by SIGTERM, after removing any half-written output.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys

import click

from .._version import __version__
from ..errors import SailError


class DataError(click.ClickException):
    """Bad data rather than bad usage: exit code 1."""

    exit_code = 1


class InternalError(click.ClickException):
    """An exception sailforce did not expect: a bug, reported in one line with exit code 70 (EX_SOFTWARE)."""

    exit_code = 70


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that every ``with`` block cleans up; exit code 143."""


__all__ = ["DataError", "InternalError", "Terminated", "cli", "main"]

EXIT_INTERRUPTED = 130  #: 128 + SIGINT, the shell's convention
EXIT_TERMINATED = 143  #: 128 + SIGTERM


#: Command name -> the module that defines it.  Modules load on first use, so
#: ``sail estimate`` does not pay for the plotting and FEM imports.
_COMMAND_MODULES = {
    "calibrate": "calibrate_cmd",
    "cell-fit": "solid_cmd",
    "check-rig": "check_rig_cmd",
    "demo": "demo_cmd",
    "design": "design_cmd",
    "estimate": "estimate_cmd",
    "export-c": "export_cmd",
    "fit-poly": "fitpoly_cmd",
    "identify": "identify_cmd",
    "plan-calibration": "plan_cmd",
    "live": "live_cmd",
    "reproduce": "reproduce_cmd",
    "robot": "robot_cmd",
    "simulate": "simulate_cmd",
    "simulate-motion": "simulate_motion_cmd",
    "statics": "statics_cmd",
    "solid": "solid_cmd",
    "solid-sweep": "solid_cmd",
    "stress": "stress_cmd",
    "tare": "calibrate_cmd",
    "validate": "validate_cmd",
}


class SailGroup(click.Group):
    """A group that loads its commands lazily and turns library errors into one-line CLI errors."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(_COMMAND_MODULES) | set(self.commands))

    def get_command(self, ctx: click.Context, name: str):
        if name not in self.commands and name in _COMMAND_MODULES:
            importlib.import_module(f"{__name__}.{_COMMAND_MODULES[name]}")  # registers the command
        return self.commands.get(name)

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """Click's main, with every error in one line: ``Error: ...`` and, for usage errors, where to read more."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.UsageError as exc:
            where = f" (see `{exc.ctx.command_path} --help`)" if exc.ctx is not None else ""
            click.echo(f"Error: {_one_line(exc.format_message())}{where}", err=True)
            sys.exit(exc.exit_code)
        except click.ClickException as exc:
            click.echo(f"Error: {_one_line(exc.format_message())}", err=True)
            sys.exit(exc.exit_code)
        except click.Abort:
            click.echo("sail: aborted", err=True)
            sys.exit(1)
        sys.exit(code if isinstance(code, int) else 0)

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except SailError as exc:
            raise DataError(str(exc)) from None
        except OSError as exc:
            name = f"{exc.filename}: " if exc.filename else ""
            raise DataError(f"{name}{exc.strerror or exc}") from None
        except MemoryError:
            raise DataError("not enough memory for this job; make the grid or the input smaller") from None
        except KeyboardInterrupt as exc:
            code = EXIT_TERMINATED if isinstance(exc, Terminated) else EXIT_INTERRUPTED
            click.echo(f"sail: {'terminated' if code == EXIT_TERMINATED else 'interrupted'}", err=True)
            sys.exit(code)
        except (click.ClickException, click.exceptions.Exit, click.Abort, SystemExit):
            raise
        except Exception as exc:
            if os.environ.get("SAIL_TRACEBACK"):
                raise
            raise InternalError(f"internal error, a bug in sailforce: {type(exc).__name__}: {exc} "
                                "(SAIL_TRACEBACK=1 shows where; please report it)") from None  # fmt: skip


def _one_line(message: str) -> str:
    return " ".join(message.split())


CONTEXT_SETTINGS = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


@click.group(cls=SailGroup, context_settings=CONTEXT_SETTINGS)
@click.version_option(__version__, "--version", prog_name="sail")
def cli() -> None:
    """SAIL: end-effector force from two link-integrated load cells.

    Angles on the command line are in degrees, counter-clockwise from +x;
    everything else is SI.
    """


#: ``SAIL_PANDAS=1`` lets pyarrow import pandas in the ``sail`` process (see :func:`_without_pandas`).
PANDAS_ENV = "SAIL_PANDAS"


def main() -> None:
    """Console-script entry point."""
    signal.signal(signal.SIGTERM, _terminate)
    _without_pandas()
    cli(prog_name="sail")


def _without_pandas() -> None:
    """Keep pandas out of the ``sail`` process, as if it were not installed.

    pyarrow imports pandas, when it is installed, on its first array
    conversion, to recognise pandas objects; no ``sail`` command hands it
    one.  That import is about 0.2 s, a fifth of a short command's time
    (``make bench``'s start-up figures).  A finder first on
    ``sys.meta_path`` refuses it, as a missing module, which pyarrow and
    every other library here take as an optional extra not present.  The
    library itself, imported by a user's program, is untouched.
    """
    if "pandas" in sys.modules or os.environ.get(PANDAS_ENV, "").strip().lower() in ("1", "true", "yes"):
        return
    if not any(isinstance(finder, _NoPandas) for finder in sys.meta_path):  # main() called again in one process
        sys.meta_path.insert(0, _NoPandas())


class _NoPandas:
    """An import finder that refuses pandas (:func:`_without_pandas`)."""

    def find_spec(self, name: str, path=None, target=None):
        if name == "pandas" or name.startswith("pandas."):
            raise ModuleNotFoundError(f"No module named {name!r} (sail runs without pandas; {PANDAS_ENV}=1 allows it)",
                                      name=name)  # fmt: skip
        return None


def _terminate(signum, frame) -> None:
    raise Terminated()
