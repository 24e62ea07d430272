"""Calibrations (and low-pass designs) as C initializers for libsail (``c/include/sail.h``).

:func:`calibration_header` writes a header holding
``static const sail_calibration NAME = {...};``: the same numbers as the
calibration file, in the layout of ``struct sail_calibration``, so that
``sail_estimate`` on the microcontroller computes what
:meth:`sailforce.calibration.file.Calibration.estimate` computes on the PC.  Every
literal goes through ``SAIL_REAL()`` with 17 significant digits, exact in a
double build and rounded once in a float build.
"""

from __future__ import annotations

import re

import numpy as np

from .calibration.file import Calibration
from .errors import ExportError
from .estimate.filters import LowPass
from .sensing.maps import MatrixCompensator

#: ``SAIL_MAX_TERMS`` in sail.h: coefficients per series (Chebyshev or power).
MAX_TERMS = 24
#: ``SAIL_MAX_SECTIONS`` in sail.h: second-order sections (Butterworth order <= 8).
MAX_SECTIONS = 4
#: ``SAIL_MAX_HALF_WINDOW`` in sail.h: half the rate window, in samples.
MAX_HALF_WINDOW = 64
#: ``SAIL_MAX_RATE_ORDER`` in sail.h: the rate filter's polynomial order.
MAX_RATE_ORDER = 4
#: ``SAIL_MAX_SINC_ORDER`` in sail.h: the longest ADC filter the multi-rate estimator takes.
MAX_SINC_ORDER = 8

_C_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

#: Keywords of C99, C11 and C23, and the macros of <stdbool.h>: never a variable's name.
C_KEYWORDS = frozenset("""
    auto break case char const continue default do double else enum extern float for goto if inline int long
    register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
    _Alignas _Alignof _Atomic _Bool _Complex _Generic _Imaginary _Noreturn _Static_assert _Thread_local
    alignas alignof bool constexpr false nullptr static_assert thread_local true typeof typeof_unqual
    _BitInt _Decimal32 _Decimal64 _Decimal128
""".split())

#: Every name c/include/sail.h declares (tests/test_libsail.py checks this list against the header), and
#: what <stddef.h>, which it includes, defines.
LIBSAIL_NAMES = frozenset("""
    SAIL_DELTA_RANGE_SLACK SAIL_DOUBLE SAIL_EXTRAPOLATED SAIL_GAP_FACTOR SAIL_H SAIL_INVALID
    SAIL_COUNTS_PER_TURN SAIL_MAX_HALF_WINDOW SAIL_MAX_RATE_ORDER SAIL_MAX_SECTIONS SAIL_MAX_TERMS
    SAIL_MODEL_MATRIX SAIL_MODEL_SEED SAIL_MOTION_UNKNOWN
    SAIL_OK SAIL_REAL SAIL_SATURATED SAIL_SINGULAR SAIL_SINGULAR_SIN_DELTA SAIL_VERSION_MAJOR SAIL_VERSION_MINOR
    sail_calibration sail_calibration_real_size sail_dynamics sail_estimate sail_estimate_block
    sail_estimate_moving sail_force sail_lowpass sail_lowpass_init sail_lowpass_process sail_lowpass_state
    sail_model_kind sail_motion_flush sail_motion_init sail_motion_state sail_motion_step sail_reading
    sail_real sail_tare_finish sail_tare_init sail_tare_process sail_tare_state
    SAIL_MAX_SINC_ORDER SAIL_MAX_TICKS SAIL_PERIOD_MEMORY SAIL_MISSED_CONVERSION SAIL_GAP_STEPS SAIL_HISTORY
    SAIL_CHECK_ADC sail_adc sail_tick sail_timed_force sail_adc_tick sail_adc_cell sail_multirate_state
    sail_multirate_init sail_multirate_step sail_multirate_flush sail_rate_filter sail_check sail_status
    SAIL_CHECK_POLICY SAIL_REZERO_MAX_BLOCKS SAIL_REZERO_POLICY_DEFAULT SAIL_CONTACT_NONE SAIL_CONTACT_FREE
    SAIL_CONTACT_HELD SAIL_REZERO_NONE SAIL_REZERO_MADE SAIL_REZERO_REFUSED_STEP SAIL_REZERO_REFUSED_TOTAL
    sail_rezero_decision sail_rezero_policy sail_rezero_block sail_rezero_event sail_rezero_state sail_rezero_init
    sail_rezero_step sail_temperature sail_temperature_correct
    NULL offsetof size_t ptrdiff_t wchar_t max_align_t
""".split())



#: What may stand in a generated C comment as it is; anything else becomes ``?``, so that no text (a file name, a
#: calibration's fields, which anyone can rewrite and re-checksum) can close the comment or smuggle in code.
_COMMENT_SAFE = re.compile(r"[^A-Za-z0-9 ._+()%:,=<>#@\[\]{}|~^'-]")


def comment_text(text: object) -> str:
    """``text`` made safe inside ``/* ... */``: printable ASCII without ``*``, ``/``, ``\\``, ``?`` or quotes.

    >>> comment_text("x */ static const int injected = 1; /*")
    'x ?? static const int injected = 1? ??'
    """
    return _COMMENT_SAFE.sub("?", str(text))


def _real(x: float) -> str:
    x = float(x)
    if not np.isfinite(x):
        raise ExportError(f"cannot export the non-finite value {x!r}")
    return f"SAIL_REAL({x!r})"


def _array(values, broken: bool = False) -> str:
    """A nested C initializer ``{...}`` for an array of numbers; ``broken``: one top-level element per line."""
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        return "{" + ", ".join(_real(v) for v in values) + "}"
    if broken:
        return "{\n        " + ",\n        ".join(_array(v) for v in values) + ",\n    }"
    return "{" + ", ".join(_array(v) for v in values) + "}"


def _padded(rows: list, width: int) -> list:
    return [list(r) + [0.0] * (width - len(r)) for r in rows]


#: The longest name exported: C99 guarantees 63 significant characters of an identifier, and the name gains
#: suffixes (``_lowpass_df2T``) and an upper-cased guard.
MAX_NAME_CHARS = 48


def _check_name(name: str, lowpass: bool = False, dynamics: bool = False, adc: bool = False,
                temperature: bool = False) -> None:  # fmt: skip
    if len(name) > MAX_NAME_CHARS:
        raise ExportError(f"--name is {len(name):,} characters long; C keeps {MAX_NAME_CHARS} at most with its suffixes "
                          "(C99: 63 significant characters); choose a shorter name")  # fmt: skip
    if not _C_NAME.match(name):
        raise ExportError(f"--name {name!r} is not a C identifier (letters, digits and _, not starting with a digit)")
    if name in C_KEYWORDS:
        raise ExportError(f"--name {name!r} is a C keyword; choose another name, such as the default sail_cal")
    if name.startswith("__") or (name[0] == "_" and name[1:2].isupper()):
        raise ExportError(f"--name {name!r} is reserved for the C implementation (it starts with __ or _ and a capital)")
    extra = ((f"{name}_lowpass", f"{name}_lowpass_df2T") if lowpass else ()) + ((f"{name}_dynamics",) if dynamics else ())
    extra += (f"{name}_adc",) if adc else ()
    extra += (f"{name}_temperature",) if temperature else ()
    for declared in (name, *extra):
        if declared in LIBSAIL_NAMES:
            raise ExportError(f"--name {name!r} would declare {declared}, which libsail's sail.h already declares; "
                              "choose another name, such as the default sail_cal")  # fmt: skip


def calibration_fields(cal: Calibration) -> list[tuple[str, str]]:
    """``(member, initializer)`` pairs of ``struct sail_calibration`` for ``cal``."""
    arm = cal.arm
    fields = [
        ("l2", _real(arm.l2)),
        ("l3", _real(arm.l3)),
        ("offset", _array(cal.offsets)),
        ("capacity", _array(cal.capacity)),
        ("delta_min", _real(cal.delta_range[0])),
        ("delta_max", _real(cal.delta_range[1])),
    ]
    model = cal.model
    if isinstance(model, MatrixCompensator):
        c = np.asarray(model.coefficients, dtype=float)
        if c.shape[0] > MAX_TERMS:
            raise ExportError(f"the matrix model has order {c.shape[0] - 1}; libsail holds order <= {MAX_TERMS - 1}")
        padded = np.zeros((MAX_TERMS, 2, 2))
        padded[: c.shape[0]] = c
        return [("kind", "SAIL_MODEL_MATRIX"), *fields, ("model", _union_member("matrix", [
            ("n_terms", str(c.shape[0])), ("cheb_lo", _real(model.delta_range[0])),
            ("cheb_hi", _real(model.delta_range[1])), ("cheb", _array(padded, broken=True))]))]  # fmt: skip
    amplitude = [fit.coefficients for fit in model.amplitude]
    phase = [fit.coefficients for fit in model.phase_deg]
    longest = max(len(p) for p in amplitude + phase)
    if longest > MAX_TERMS:
        raise ExportError(f"the seed model has a polynomial of order {longest - 1}; libsail holds order <= {MAX_TERMS - 1}")
    return [("kind", "SAIL_MODEL_SEED"), *fields, ("model", _union_member("seed", [
        ("amplitude_terms", "{" + ", ".join(str(len(p)) for p in amplitude) + "}"),
        ("phase_terms", "{" + ", ".join(str(len(p)) for p in phase) + "}"),
        ("amplitude", _array(_padded(amplitude, MAX_TERMS), broken=True)),
        ("phase_deg", _array(_padded(phase, MAX_TERMS), broken=True))]))]  # fmt: skip


def _union_member(member: str, fields: list[tuple[str, str]]) -> str:
    """``{.member = {.field = value, ...}}``: the tagged union's member, in braces rather than nested
    designators (``.model.matrix.n_terms``), which C++ (an Arduino sketch) does not accept."""
    body = "".join(f"        .{name} = {value.replace(chr(10), chr(10) + '    ')},\n" for name, value in fields)
    return f"{{.{member} = {{\n{body}    }}}}"


def lowpass_fields(lowpass: LowPass) -> list[tuple[str, str]]:
    """``(member, initializer)`` pairs of ``struct sail_lowpass``: the SOS and their unit steady state."""
    from scipy import signal

    sos = np.asarray(lowpass.sos, dtype=float)
    if sos.shape[0] > MAX_SECTIONS:
        raise ExportError(f"a low-pass of {sos.shape[0]} sections; libsail holds <= {MAX_SECTIONS} (order <= 8)")
    zi = signal.sosfilt_zi(sos)
    pad = MAX_SECTIONS - sos.shape[0]
    return [("n_sections", str(sos.shape[0])),
            ("sos", _array(np.vstack([sos, np.zeros((pad, 6))]), broken=True)),
            ("zi", _array(np.vstack([zi, np.zeros((pad, 2))]), broken=True))]  # fmt: skip


def df2t_coefficients(lowpass: LowPass) -> np.ndarray:
    """``(5 n_sections,)``: the filter in CMSIS-DSP's ``arm_biquad_cascade_df2T`` layout, {b0, b1, b2, -a1, -a2} per stage.

    CMSIS writes its difference equation with the feedback terms added
    (y = b0 x + d1; d1 = b1 x + a1 y + d2; d2 = b2 x + a2 y), so its a1 and
    a2 are scipy's with the sign changed (``arm_biquad_cascade_df2T_init_f32``).
    """
    sos = np.asarray(lowpass.sos, dtype=float)
    return np.column_stack([sos[:, 0], sos[:, 1], sos[:, 2], -sos[:, 4], -sos[:, 5]]).ravel()


def dynamics_fields(cal: Calibration, sample_rate_hz: float) -> list[tuple[str, str]]:
    """``(member, initializer)`` pairs of ``struct sail_dynamics``: the shear coefficients and the rate filter."""
    from .motion.differentiate import kernel_polynomials

    term = cal.dynamics
    dt = 1.0 / sample_rate_hz
    width = term.differentiator.window(dt)
    half = width // 2
    if half > MAX_HALF_WINDOW:
        raise ExportError(f"a {term.differentiator.window_s:g} s rate window at {sample_rate_hz:g} Hz is {width} samples; "
                          f"libsail holds up to {2 * MAX_HALF_WINDOW + 1}")  # fmt: skip
    order = term.differentiator.order
    if order > MAX_RATE_ORDER:
        raise ExportError(f"the rate filter has order {order}; libsail's holds order <= {MAX_RATE_ORDER}")
    rate, accel = np.zeros(MAX_RATE_ORDER + 1), np.zeros(MAX_RATE_ORDER + 1)
    rate[: order + 1], accel[: order + 1] = kernel_polynomials(width, order, dt)
    k = term.shear_model(cal.arm).coefficients
    return [("l1", _real(cal.arm.l1)), ("l2", _real(cal.arm.l2)), ("k", _array(k, broken=True)), ("dt", repr(dt)),
            ("half", str(half)), ("order", str(order)), ("rate", _doubles(rate)), ("accel", _doubles(accel))]  # fmt: skip


def adc_fields(cal: Calibration, sample_rate_hz: float) -> list[tuple[str, str]]:
    """``(member, initializer)`` pairs of ``struct sail_adc``: the ADC's period and filter, the identified delay, the tick."""
    adc = cal.adc
    if not 1 <= adc.sinc_order <= MAX_SINC_ORDER:
        raise ExportError(f"the ADC's filter is sinc^{adc.sinc_order}; libsail's multi-rate estimator takes sinc^1 to "
                          f"sinc^{MAX_SINC_ORDER}")  # fmt: skip
    return [("period", repr(adc.period_s)), ("sinc_order", str(adc.sinc_order)), ("delay", repr(float(cal.adc_delay_s))),
            ("tick", repr(1.0 / sample_rate_hz))]  # fmt: skip


def _doubles(values) -> str:
    """A C initializer of double literals (members that are double in every build)."""
    if not np.all(np.isfinite(values)):
        raise ExportError("cannot export non-finite values")
    return "{" + ", ".join(repr(float(v)) for v in values) + "}"


def _initializer(ctype: str, name: str, fields: list[tuple[str, str]]) -> str:
    body = "".join(f"    .{member} = {value},\n" for member, value in fields)
    return f"static const {ctype} {name} = {{\n{body}}};\n"


def calibration_header(cal: Calibration, name: str = "sail_cal", *, source: str = "", lowpass: LowPass | None = None,
                       sample_rate_hz: float | None = None) -> str:  # fmt: skip
    """The text of a C header defining ``name`` (and ``name_lowpass`` when a filter is given).

    With a dynamic term in ``cal`` and a ``sample_rate_hz``, it also defines
    ``name_dynamics`` (``struct sail_dynamics``) for sail_motion_init.
    """
    dynamics = cal.dynamics is not None and sample_rate_hz is not None
    multirate = cal.multirate and sample_rate_hz is not None
    _check_name(name, lowpass is not None, dynamics, multirate, cal.temperature is not None)
    guard = f"SAIL_CALIBRATION_{name.upper()}_H"
    lo, hi = np.degrees(cal.delta_range)
    c = comment_text
    lines = [
        f"/* Generated by {c(cal.software.split(' ')[0])} `sail export-c`{' from ' + c(source) if source else ''}; do not edit.",
        f" * Calibration created {c(cal.created or 'unknown')} by {c(cal.software)}; data sha256 {c(cal.data_sha256 or 'unknown')}.",
        f" * Model {cal.kind}; delta calibrated over {lo:.6g} .. {hi:.6g} deg; loads in {c(cal.load_unit)}.",
    ]
    if lowpass is not None:
        lines.append(f" * Low-pass: Butterworth order {lowpass.order}, {lowpass.cutoff_hz:g} Hz at {lowpass.sample_rate_hz:g} Hz.")
    if dynamics:
        lines.append(f" * Dynamic term ({c(cal.dynamics_source)}) with a {cal.dynamics.differentiator.window_s:g} s rate window "
                     f"at {sample_rate_hz:g} Hz: estimates come out half a window late.")
    text = "\n".join(lines) + " */\n"
    text += f"#ifndef {guard}\n#define {guard}\n\n#include \"sail.h\"\n\n"
    text += _initializer("sail_calibration", name, calibration_fields(cal))
    if lowpass is not None:
        text += "\n" + _initializer("sail_lowpass", f"{name}_lowpass", lowpass_fields(lowpass))
        stages = int(np.asarray(lowpass.sos).shape[0])
        text += (f"\n/* The same low-pass for CMSIS-DSP: arm_biquad_cascade_df2T_init_f32(&inst, {name.upper()}_LOWPASS_STAGES,\n"
                 f" * {name}_lowpass_df2T, state) with float state[2 * stages] per cell; start it at steady state as\n"
                 f" * state[2 s + j] = zi[s][j] x0 for the first reading x0 (zi from {name}_lowpass). */\n"
                 f"#define {name.upper()}_LOWPASS_STAGES {stages}\n"
                 f"static const sail_real {name}_lowpass_df2T[5 * {stages}] = {_array(df2t_coefficients(lowpass))};\n")
    if dynamics:
        text += "\n" + _initializer("sail_dynamics", f"{name}_dynamics", dynamics_fields(cal, sample_rate_hz))
        text += f"#define {name.upper()}_HAS_DYNAMICS 1  /* for #ifdef in firmware built on several calibrations */\n"
    if multirate:
        text += (f"\n/* The cells' ADC ({c(cal.adc.model)}) for sail_multirate_init, with encoder ticks at {sample_rate_hz:g} Hz. */\n"
                 + _initializer("sail_adc", f"{name}_adc", adc_fields(cal, sample_rate_hz)))
        text += f"#define {name.upper()}_HAS_ADC 1\n"
    if cal.temperature is not None:
        t = cal.temperature
        text += ("\n/* The cells' zero [raw/degC] and span [1/degC] coefficients, for sail_temperature_correct. */\n"
                 + _initializer("sail_temperature", f"{name}_temperature", [
                     ("reference_C", f"SAIL_REAL({t.reference_C!r})"),
                     ("zero_per_C", "{" + ", ".join(f"SAIL_REAL({v!r})" for v in t.zero_per_C) + "}"),
                     ("span_per_C", "{" + ", ".join(f"SAIL_REAL({v!r})" for v in t.span_per_C) + "}")])
                 + f"#define {name.upper()}_HAS_TEMPERATURE 1\n")  # fmt: skip
    return text + f"\n#endif /* {guard} */\n"
