"""``sail simulate-motion``: a simulated rig's recordings, at rest and moving, with the truth beside them."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
from rich.console import Console

from .._version import __version__
from ..adc import PRESETS
from ..adc.conversions import MIN_PLANT_RATE_HZ
from ..io.files import check_output, check_sidecar, numeric_table_writer, table_format, write_json
from ..motion.dynamics import base_parameters, inertial_parameters, parameter_vector
from ..motion.multirate import HOLD_S, multirate_columns, record_holds, record_multirate
from ..motion.reaching import reaching, record
from ..motion.session import PUSH_BAND_HZ, tremor
from ..reference.sensor import MOUNTS, REFERENCE_SENSOR_COLUMNS, ReferenceSensor, simulate_reference
from ..synthetic import NoiseModel, calibration_session, session_offsets
from . import cli
from ._options import FINITE, PrimaryOption, load_robot, robot_option

SESSIONS = ("static", "free", "task", "push", "therapy")

#: Each session's rest at each target [s] unless --dwell-s: a push session holds still long enough for the
#: reference calibration's rows at rest (sailforce.workflows.reference_calibration_run).
DWELL_S = {"push": 1.5}
DEFAULT_DWELL_S = 0.3

#: Motion sessions longer than this are refused: an hour at 1 kHz is 3.6 M rows, beyond any lab session.
MAX_DURATION_S = 3600.0

MOTION_COLUMNS = ("t_s", "theta1_deg", "theta2_deg", "load1", "load2", "true_fx_N", "true_fy_N")
STATIC_COLUMNS = ("theta1_deg", "theta2_deg", "load1", "load2", "fx_N", "fy_N")
#: With a real ADC: the multi-rate format (docs/reference/multirate.md), the conversions' instants beside the loads.
MULTIRATE_MOTION_COLUMNS = ("t_s", "theta1_deg", "theta2_deg", "load1", "load2", "load1_t_s", "load2_t_s", "true_fx_N", "true_fy_N")
#: A therapy session: the cells' temperature and whether a hand holds the handle, beside the readings.
THERAPY_COLUMNS = ("t_s", "theta1_deg", "theta2_deg", "load1", "load2", "temperature_C", "contact", "true_fx_N", "true_fy_N")
MULTIRATE_STATIC_COLUMNS = ("t_s", "theta1_deg", "theta2_deg", "load1", "load2", "load1_t_s", "load2_t_s", "fx_N", "fy_N")


@cli.command("simulate-motion")
@robot_option
@click.option("--session", type=click.Choice(SESSIONS), default="free", show_default=True,
              help="static: pulley-and-weights calibration poses (for `sail calibrate`); free: the motors move the "
                   "arm, nobody holds it (for --free-motion); task: a hand pulls toward each target; push: a hand "
                   "pushes the handle about in every direction (--push-N; with --reference, for `sail calibrate "
                   "--reference`); therapy: "
                   "--minutes of reaches, the handle let go now and then, the cells drifting (docs/reference/drift.md).")
@click.option("--reach-m", "reach", cls=PrimaryOption, type=FINITE, default=0.3, show_default=True, help="Reach length [m].")
@click.option("--reaches", type=click.IntRange(1, 10_000), default=16, show_default=True, help="Reaches, one after the other.")
@click.option("--peak-speed-mps", "peak_speed", cls=PrimaryOption, type=FINITE, default=0.75, show_default=True,
              help="Peak hand speed of each minimum-jerk reach [m/s] (0.75 m/s over 0.3 m: 3.1 m/s^2 peak).")
@click.option("--dwell-s", "dwell", cls=PrimaryOption, type=FINITE, default=None,
              help=f"Rest at each target [s]. Default: {DEFAULT_DWELL_S:g}; push: {DWELL_S['push']:g}.")
@click.option("--push-N", "--push-n", "push_N", type=click.FloatRange(0.0), default=10.0, show_default=True,
              help="push: the hand's force, rms per axis, 0.1-2 Hz [N].")
@click.option("--reference", "reference", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="REF.csv", help="Also write what a six-axis F/T sensor under the handle records (t_s, fx, fy, "
              "fz, tx, ty, tz in its own frame, on its own clock), for `sail calibrate --reference` and `sail "
              "validate`; motion sessions with the ideal ADC.")
@click.option("--reference-rate-Hz", "--reference-rate-hz", "ref_rate", type=FINITE, default=ReferenceSensor.rate_Hz,
              show_default=True, help="The reference sensor's sampling rate [Hz].")
@click.option("--reference-noise-N", "--reference-noise-n", "ref_noise", type=click.FloatRange(0.0),
              default=ReferenceSensor.noise_N, show_default=True, help="Its noise, rms per force axis [N].")
@click.option("--reference-mount-deg", "ref_mount", type=FINITE, default=float(np.degrees(ReferenceSensor.mount_rad)),
              show_default=True, help="Its x axis from the link's x axis (or the base's) [deg].")
@click.option("--reference-clock-offset-s", "ref_clock", type=FINITE, default=ReferenceSensor.clock_offset_s,
              show_default=True, help="Its clock less the robot's [s].")
@click.option("--reference-on", "ref_on", type=click.Choice(MOUNTS), default=ReferenceSensor.on, show_default=True,
              help="link: it turns with the handle's link (theta1); base: it does not.")
@click.option("--hand-stiffness-N-per-m", "--hand-stiffness-n-per-m", "stiffness", cls=PrimaryOption, type=FINITE,
              default=100.0, show_default=True, help="task: the hand pulls toward the reach's target with this spring [N/m].")
@click.option("--sample-rate-Hz", "--sample-rate-hz", "rate", cls=PrimaryOption, type=FINITE, default=1000.0,
              show_default=True, help="Sampling rate [Hz].")
@click.option("--encoder-bits", type=click.IntRange(8, 32), default=16, show_default=True,
              help="Encoder resolution: 2^bits counts per revolution.")
@click.option("--noise", "noise_fraction", type=FINITE, default=NoiseModel().noise_fraction, show_default=True,
              help="Cell noise, fraction of rated output (Gaussian).")
@click.option("--adc", "adc_name", type=click.Choice(tuple(PRESETS)), default=None,
              help="The cells' ADC: each cell converts on its own clock through its filter, the plant integrated at "
                   "10 kHz, written in the multi-rate format. Default: the robot file's [adc], else ideal (a reading "
                   "at every tick, as before).")
@click.option("--hold-s", "hold_s", cls=PrimaryOption, type=FINITE, default=HOLD_S, show_default=True,
              help="static, with an ADC: how long each pose and force is held [s].")
@click.option("--minutes", type=click.FloatRange(0.1, 60.0), default=30.0, show_default=True,
              help="therapy: the session's length [min].")
@click.option("--release-every-s", "release_every", cls=PrimaryOption, type=FINITE, default=60.0, show_default=True,
              help="therapy: the hand lets go of the handle at the end of every this many seconds...")
@click.option("--release-s", "release_s", type=click.FloatRange(0.0), default=10.0, show_default=True,
              help="therapy: ...for this long [s] (0: never).")
@click.option("--tremor-N", "--tremor-n", "tremor_N", type=click.FloatRange(0.0), default=0.3, show_default=True,
              help="therapy: a holding hand's tremor, rms per axis, 1-12 Hz [N].")
@click.option("--drift/--no-drift", default=True, show_default=True,
              help="therapy: the cells' zero and span drift with temperature, creep and warm-up (sailforce.drift's "
                   "datasheet defaults); --no-drift for the drift-free reference.")
@click.option("--rig", type=click.IntRange(0), default=1, show_default=True,
              help="Which simulated rig: its cells' zero offsets, the same in every session made with it.")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True, help="The session's noise draw.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="OUT.csv or OUT.parquet; OUT.csv.json beside it holds the truth (offsets, base parameters).")
def simulate_motion_command(robot_path, session, reach, reaches, peak_speed, dwell, push_N, reference, ref_rate,
                            ref_noise, ref_mount, ref_clock, ref_on, stiffness, rate, encoder_bits, noise_fraction,
                            adc_name, hold_s, minutes, release_every, release_s, tremor_N, drift, rig, seed,
                            output):  # fmt: skip
    """Simulate a rig's recordings: a static calibration session, or reaching movements with inertia.

    \b
    A lab's pipeline, simulated end to end (same --rig for all three):
      sail simulate-motion --session static -o static.csv
      sail simulate-motion --session free -o free.csv
      sail calibrate static.csv --free-motion free.csv -o cal.json
      sail simulate-motion --session task -o task.csv
      sail estimate --calibration cal.json task.csv -o forces.csv

    Motion sessions: minimum-jerk reaches of --reach-m between targets on a
    circle, 8 directions, quantized encoders and the cells' noise; columns
    t_s, theta1_deg, theta2_deg, load1, load2 (HX711 counts) and the hand's
    true force true_fx_N, true_fy_N.  The robot file's [handle] and [plane]
    set the handle mass and the tilt.  The static session is the
    pulley-and-weights calibration (fx_N, fy_N the applied force).  The
    therapy session adds temperature_C and contact (1 while a hand holds
    the handle); its loads drift (--no-drift: they do not), for `sail
    estimate --rezero`.  The push session's hand pushes the handle about
    (--push-N) while the robot moves it; --reference adds the recording of a
    six-axis sensor under the handle (docs/guide/reference.md).
    """
    table_format(output)
    sidecar = check_sidecar(output)
    check_output(output, {"the --robot file": robot_path})
    check_output(sidecar, {"the --robot file": robot_path}, flag=f"the sidecar of -o {output},")
    dwell = DWELL_S.get(session, DEFAULT_DWELL_S) if dwell is None else dwell
    sensor = None
    if reference is not None:
        table_format(reference, "--reference")
        check_output(reference, {"the --robot file": robot_path, "-o": output, "the sidecar of -o": sidecar}, flag="--reference")
        if session == "static":
            raise click.UsageError("--reference records a motion session (free, task, push, therapy); the static "
                                   "session's forces are the weights'")  # fmt: skip
        if not ref_rate > 0:
            raise click.BadParameter(f"{ref_rate:g} must be positive", param_hint="--reference-rate-Hz")
        sensor = ReferenceSensor(rate_Hz=ref_rate, noise_N=ref_noise, mount_rad=float(np.radians(ref_mount)),
                                 clock_offset_s=ref_clock, on=ref_on)  # fmt: skip
    for name, value in (("--reach-m", reach), ("--peak-speed-mps", peak_speed), ("--sample-rate-Hz", rate)):
        if not value > 0:
            raise click.BadParameter(f"{value:g} must be positive", param_hint=name)
    if dwell < 0 or noise_fraction < 0 or stiffness < 0:
        raise click.UsageError("--dwell-s, --noise and --hand-stiffness-N-per-m cannot be negative")
    robot = load_robot(robot_path)
    adc = PRESETS[adc_name] if adc_name is not None else robot.adc
    if not hold_s > 0:
        raise click.BadParameter(f"{hold_s:g} must be positive", param_hint="--hold-s")
    noise = NoiseModel(noise_fraction=noise_fraction)
    offsets = session_offsets(robot, noise, rig)
    console = Console(stderr=True)
    truth = {"software": f"sailforce {__version__}", "session": session, "rig": rig, "seed": seed,
             "offsets_counts": offsets.tolist(), "robot_file": str(robot_path) if robot_path else None, "robot": robot}  # fmt: skip
    if not adc.ideal:
        truth |= {"adc": {"model": adc.model, "rate_Hz": adc.rate_Hz, "sinc_order": adc.sinc_order}}
    if sensor is not None and not adc.ideal:
        raise click.UsageError(f"--reference simulates the ideal ADC's sessions (a reading at every tick); leave out "
                               f"--adc {adc.model}")  # fmt: skip
    if session == "push" and not adc.ideal:
        raise click.UsageError(f"the push session simulates the ideal ADC (a reading at every tick); leave out --adc {adc.model}")
    if not adc.ideal and session == "static":
        t1, t2, fx, fy, _, _ = calibration_session(robot, seed=seed + 1, noise=noise, offsets=offsets)
        holds = record_holds(robot, adc, t1, t2, fx, fy, hold_s=hold_s, control_rate_hz=rate, noise=noise,
                             counts_per_rev=1 << encoder_bits, seed=seed, offsets=offsets)  # fmt: skip
        with numeric_table_writer(output, MULTIRATE_STATIC_COLUMNS, missing="") as write:
            write(multirate_columns(holds, ("fx_N", "fy_N")))
        truth |= {"clocks_Hz": [c.clock.rate_Hz for c in holds.cells], "holds": int(t1.size), "hold_s": hold_s}
        rows = holds.t.size
    elif session == "therapy":
        rec = _therapy(robot, output, truth, adc, minutes=minutes, release_every=release_every, release_s=release_s,
                        stiffness=stiffness, tremor_N=tremor_N, drift=drift, reach=reach, peak_speed=peak_speed,
                        rate=rate, noise=noise, encoder_bits=encoder_bits, seed=seed, rig=rig, offsets=offsets)  # fmt: skip
        rows = rec.t.size
    elif session == "static":
        t1, t2, fx, fy, counts, _ = calibration_session(robot, seed=seed + 1, noise=noise, offsets=offsets)
        with numeric_table_writer(output, STATIC_COLUMNS) as write:
            write({"theta1_deg": np.degrees(t1), "theta2_deg": np.degrees(t2), "load1": counts[:, 0],
                   "load2": counts[:, 1], "fx_N": fx, "fy_N": fy})  # fmt: skip
        rows = t1.size
    else:
        duration = reaches * (1.875 * reach / peak_speed + dwell)
        if duration > MAX_DURATION_S:
            raise click.UsageError(f"{reaches} reaches last {duration:.0f} s, more than {MAX_DURATION_S:.0f} s; "
                                   "ask for fewer reaches")  # fmt: skip
        if adc.ideal:
            motion = reaching(robot, reach=reach, reaches=reaches, peak_speed=peak_speed, dwell=dwell, sample_rate_hz=rate)
            push = None
            if session == "push":
                push = tremor(motion.t, push_N, np.random.default_rng([seed, 1]), PUSH_BAND_HZ)
                truth |= {"push_N": push_N, "push_band_Hz": list(PUSH_BAND_HZ)}
            rec = record(robot, motion, hand_stiffness=stiffness if session == "task" else 0.0, noise=noise,
                         counts_per_rev=1 << encoder_bits, seed=seed, offsets=offsets, force=push)  # fmt: skip
            with numeric_table_writer(output, MOTION_COLUMNS) as write:
                write({"t_s": rec.t, "theta1_deg": np.degrees(rec.theta[:, 0]), "theta2_deg": np.degrees(rec.theta[:, 1]),
                       "load1": rec.loads[:, 0], "load2": rec.loads[:, 1], "true_fx_N": rec.force[:, 0],
                       "true_fy_N": rec.force[:, 1]})  # fmt: skip
        else:
            multi = record_multirate(robot, adc, reach=reach, reaches=reaches, peak_speed=peak_speed, dwell=dwell,
                                     hand_stiffness=stiffness if session == "task" else 0.0, control_rate_hz=rate,
                                     plant_rate_hz=_plant_rate(rate), noise=noise, counts_per_rev=1 << encoder_bits,
                                     seed=seed, offsets=offsets)  # fmt: skip
            motion = multi.motion
            with numeric_table_writer(output, MULTIRATE_MOTION_COLUMNS, missing="") as write:
                write(multirate_columns(multi))
            truth |= {"clocks_Hz": [c.clock.rate_Hz for c in multi.cells], "plant_rate_Hz": _plant_rate(rate),
                      "conversions_overwritten": [c.overwritten for c in multi.cells]}  # fmt: skip
            rec = multi
        base = base_parameters(robot.arm)
        truth |= {"base_parameters": dict(zip(base.names, base.of(parameter_vector(
                      robot.arm, inertial_parameters(robot), robot.plane.gravity)).tolist())),
                  "counts_per_newton_of_shear": rec.gain, "sample_rate_Hz": rate, "encoder_bits": encoder_bits,
                  "peak_hand_acceleration_mps2": float(np.max(np.linalg.norm(_hand_acceleration(robot, motion), axis=1)))}  # fmt: skip
        rows = rec.t.size
    if sensor is not None:
        with numeric_table_writer(reference, REFERENCE_SENSOR_COLUMNS) as write:
            write(simulate_reference(rec.t, rec.motion.q[:, 0], rec.force, sensor, seed=seed + 2))
        truth |= {"reference": {"file": str(reference), "rate_Hz": sensor.rate_Hz, "noise_N": sensor.noise_N,
                                "mount_deg": ref_mount, "clock_offset_s": sensor.clock_offset_s,
                                "offsets_N": list(sensor.offsets_N), "on": sensor.on}}  # fmt: skip
    write_json(sidecar, truth)
    console.print(f"wrote {rows:,} rows of the {session} session to {output} (the truth in {sidecar})", highlight=False)


def _therapy(robot, output, truth, adc, *, minutes, release_every, release_s, stiffness, tremor_N, drift, reach,
             peak_speed, rate, noise, encoder_bits, seed, rig, offsets):  # fmt: skip
    from dataclasses import asdict

    from ..drift import Drift, TemperatureProfile
    from ..motion.session import therapy_session

    if not adc.ideal:
        raise click.UsageError(f"the therapy session simulates the ideal ADC (a reading at every tick): drift is slow "
                               f"beside any ADC's window; leave out --adc {adc.model}")  # fmt: skip
    if release_s >= release_every:
        raise click.UsageError("--release-s must be shorter than --release-every-s: a hand holds the handle sometimes")
    model, profile = (Drift() if drift else Drift.none()), TemperatureProfile()
    s = therapy_session(robot, minutes=minutes, release_every_s=release_every, release_s=release_s,
                        hand_stiffness=stiffness, tremor_N=tremor_N, drift=model, reach=reach, peak_speed=peak_speed,
                        sample_rate_hz=rate, noise=noise, counts_per_rev=1 << encoder_bits, seed=seed, rig=rig,
                        offsets=offsets)  # fmt: skip
    r = s.recording
    with numeric_table_writer(output, THERAPY_COLUMNS) as write:
        write({"t_s": r.t, "theta1_deg": np.degrees(r.theta[:, 0]), "theta2_deg": np.degrees(r.theta[:, 1]),
               "load1": r.loads[:, 0], "load2": r.loads[:, 1], "temperature_C": s.temperature_C, "contact": s.contact,
               "true_fx_N": r.force[:, 0], "true_fy_N": r.force[:, 1]})  # fmt: skip
    truth |= {"drift": asdict(model), "temperature": asdict(profile), "minutes": minutes,
              "release_every_s": release_every, "release_s": release_s, "tremor_N": tremor_N, "sample_rate_Hz": rate,
              "drift_counts_final": s.drift_counts[-1].tolist(), "drift_counts_max": np.abs(s.drift_counts).max(0).tolist()}  # fmt: skip
    return r


def _plant_rate(control_rate: float) -> float:
    """The plant's rate: the smallest whole multiple of the control rate at or above 10 kHz."""
    return control_rate * max(1, int(np.ceil(MIN_PLANT_RATE_HZ / control_rate - 1e-9)))


def _hand_acceleration(robot, motion) -> np.ndarray:
    from ..kinematics import jacobian

    J = jacobian(robot.arm, motion.q[:, 0], motion.q[:, 1])
    dt = motion.t[1] - motion.t[0] if motion.t.size > 1 else 1.0
    xd = (J @ motion.qd[..., None])[..., 0]
    return np.gradient(xd, dt, axis=0)
