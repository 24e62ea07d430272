"""``sail export-c``: a calibration as a C initializer for libsail."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.console import Console

from ..calibration.file import Calibration
from ..export_c import calibration_header
from ..io.files import atomic_writer, check_output
from . import cli
from ._options import lowpass_options, make_lowpass


@cli.command("export-c")
@click.argument("calibration", metavar="CAL.json", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True, path_type=Path), default=Path("sail_calibration.h"),
              show_default=True, help="Header to write ('-' for stdout).")  # fmt: skip
@click.option("--name", default="sail_cal", show_default=True, help="C name of the sail_calibration constant.")
@lowpass_options
def export_c_command(calibration, output, name, lowpass_hz, sample_rate_hz, lowpass_order):
    """Write CAL.json as `static const sail_calibration NAME = {...};` for libsail (c/include/sail.h).

    The header compiles with the library in float or double builds; both
    model kinds (seed and matrix) are supported.  With --lowpass-hz it also
    holds the filter's second-order sections as `sail_lowpass NAME_lowpass`,
    for sail_lowpass_init.  When the calibration has a dynamic term (sail
    calibrate --free-motion), --sample-rate-Hz (the encoders' and cells'
    sampling rate) also exports it as `sail_dynamics NAME_dynamics`, with
    the rate filter for that rate, for sail_motion_init.  A calibration with
    a real ADC (an [adc] table) also exports `sail_adc NAME_adc` with
    --sample-rate-Hz (the encoders' tick rate), for sail_multirate_init.
    """
    check_output(output, {"the calibration file": calibration})
    cal = Calibration.load(calibration)
    lowpass = make_lowpass(lowpass_hz, sample_rate_hz, lowpass_order, rate_alone=cal.dynamics is not None)
    console = Console(stderr=True)
    if cal.dynamics is not None and sample_rate_hz is None:
        console.print("note: the calibration's dynamic term is not exported; give --sample-rate-Hz (the sampling rate "
                      "of the encoders and cells) to export it", highlight=False)  # fmt: skip
    if cal.multirate and sample_rate_hz is None:
        console.print(f"note: the calibration's ADC ({cal.adc.model}) is not exported; give --sample-rate-Hz (the "
                      "encoders' tick rate) to export it for sail_multirate_init", highlight=False)  # fmt: skip
    if sample_rate_hz is not None and not sample_rate_hz > 0:
        raise click.BadParameter(f"{sample_rate_hz:g} Hz is not a sample rate", param_hint="--sample-rate-Hz")
    text = calibration_header(cal, name, source=calibration.name, lowpass=lowpass, sample_rate_hz=sample_rate_hz)
    if str(output) == "-":
        sys.stdout.write(text)
        return
    with atomic_writer(output) as stream:
        stream.write(text)
    extra = [f"`{name}_lowpass`"] * (lowpass is not None)
    extra += [f"`{name}_dynamics`"] * (cal.dynamics is not None and sample_rate_hz is not None)
    extra += [f"`{name}_adc`"] * (cal.multirate and sample_rate_hz is not None)
    console.print(f"wrote {output}: {cal.kind} calibration `{name}`" + "".join(f" and {e}" for e in extra))
