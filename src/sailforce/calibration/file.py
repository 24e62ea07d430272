"""The calibration: a frozen dataclass, its JSON file, and its still-arm estimate.

The file format (``schema_version`` 1) is described once, in
``calibration.schema.json`` (JSON Schema 2020-12, shipped beside this module):
every field, its unit, its bounds and the text patterns a field may hold;
every file sailforce writes is validated against it in the tests.  The
loader here checks what a schema cannot: the checksum (SHA-256 of the
canonical JSON, sorted keys and compact, of everything else), that the
numbers are finite and the map invertible, and the same patterns
(:data:`TEXT_FIELDS`, which a test holds equal to the schema's).

It is written atomically.  Loading validates every field and the checksum
and raises :class:`CalibrationFileError` naming the file and the field.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NoReturn

import numpy as np

from .._version import __version__
from ..adc import ADC
from ..arm import Arm
from ..drift import TemperatureCompensation
from ..errors import CalibrationFileError, GeometryError, InputError, SailError
from ..estimate.dynamic import DynamicTerm
from ..estimate.estimator import estimate_calibrated
from ..io.files import atomic_writer
from ..motion.differentiate import Differentiator
from ..motion.dynamics import PARAMETERS
from ..sensing.maps import AmplitudePhaseCompensator, MatrixCompensator
from ..sensing.polynomial import PolynomialFit

SCHEMA_VERSION = 1
REQUIRED = ("schema_version", "software", "created", "data_sha256", "units", "robot", "offsets", "capacity",
            "delta_range", "load_range", "model", "metrics", "checksum")  # fmt: skip



#: The text fields, as the patterns they must match: they reach C comments (``sail export-c``), the page and
#: reports, and anyone can recompute the checksum, so none may carry ``*/``, a newline or markup.
TEXT_FIELDS = {
    "created": (re.compile(r"(\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d{1,6})?(Z|[+-]\d{2}:\d{2})?)?\Z"),
                "UTC time in ISO 8601, such as 2026-12-01T20:17:26+00:00"),
    "software": (re.compile(r"[A-Za-z0-9][A-Za-z0-9 ._+()-]{0,79}\Z"), "up to 80 letters, digits, spaces and ._+()-"),
    "data_sha256": (re.compile(r"([0-9a-f]{64})?\Z"), "64 lower-case hexadecimal digits, or empty"),
    "units.load": (re.compile(r"[A-Za-z0-9µ%][A-Za-z0-9µ% ._/()-]{0,31}\Z"), "up to 32 letters, digits, spaces and ._/()%-"),
}  # fmt: skip
#: What an ADC's model name may hold (a preset's name, or "custom", with " (modified)"): no quotes, no comment ends.
ADC_MODEL = re.compile(r"[a-z0-9][a-z0-9 ._()-]{0,47}\Z")
ADC_MODEL_RULE = "up to 48 lower-case letters, digits, spaces and ._()-"

#: A full cell must stand for a hand force within these bounds [N], nine orders of magnitude either side of a newton,
#: at every calibrated pose: far outside them the numbers are not a calibration (an amplitude of 1e-300 would give
#: F = 0 on every row, and a cell that never saturates hides overloads).
FULL_SCALE_FORCE_N = (1e-9, 1e9)

#: The largest raw number (load, offset, capacity) a calibration may hold: 1e15, beyond any ADC's counts and any unit's.
MAX_RAW = 1e15

#: The sensing map's condition number beyond which the force inversion is meaningless in float64.
MAX_CONDITION = 1e10

#: Where a dynamic term may come from.
DYNAMICS_SOURCES = ("free-motion", "reference", "prior")

#: Poses at which the sensing map is checked, spread evenly over the calibrated delta range.
CHECK_POSES = 9


def check_text(name: str, value: object) -> str:
    """``value`` as the text field ``name`` (:data:`TEXT_FIELDS`); raises ``ValueError`` naming the rule."""
    pattern, rule = TEXT_FIELDS[name]
    if not isinstance(value, str) or not pattern.match(value):
        shown = value if not isinstance(value, str) else value[:60] + ("..." if len(value) > 60 else "")
        raise InputError(f"{name} = {shown!r}: expected {rule}")
    return value


@dataclass(frozen=True, kw_only=True)
class Calibration:
    """A fitted calibration: raw readings and joint angles in, end-effector force out.

    >>> import numpy as np
    >>> from sailforce.sensing.maps import MatrixCompensator
    >>> arm = Arm()
    >>> c = np.zeros((1, 2, 2)); c[0] = np.diag([1 / 740, 1 / 528])   # loads = T_i / k_i
    >>> cal = Calibration(arm=arm, model=MatrixCompensator(arm, c, (0.2, 2.2)), offsets=(0.0, 0.0),
    ...                   capacity=(10.0, 10.0), delta_range=(0.2, 2.2))
    >>> fx, fy, status = cal.estimate(np.pi / 2, 0.0, 0.0, 3.0 / 528)
    >>> round(float(fx), 9), round(float(fy), 9), int(status)
    (0.0, 10.0, 0)
    """

    arm: Arm
    model: MatrixCompensator | AmplitudePhaseCompensator
    offsets: tuple[float, float]
    capacity: tuple[float, float]  #: |load - offset| beyond this is saturated [raw]
    delta_range: tuple[float, float]  #: calibrated delta [rad]
    load_range: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))  #: raw seen when calibrating
    load_unit: str = "raw"
    metrics: dict = field(default_factory=dict, compare=False)
    data_sha256: str = ""
    created: str = ""
    software: str = f"sailforce {__version__}"
    dynamics: DynamicTerm | None = None  #: the inertial and gravity loads to subtract while moving
    dynamics_source: str = ""  #: "free-motion" or "reference" (identified), or "prior" (from the robot file)
    adc: ADC = ADC()  #: the cells' ADC; a real one (not ``ideal``) makes estimates multi-rate (sailforce.estimate.multirate)
    adc_delay_s: float = 0.0  #: the filter's delay identified beyond the model's N T / 2 [s] (free-motion calibration)
    temperature: TemperatureCompensation | None = None  #: the cells' zero and span per °C, when the data spanned temperatures

    @property
    def multirate(self) -> bool:
        """Whether readings come from a real ADC: one conversion now and then, each a filtered average."""
        return not self.adc.ideal

    @property
    def kind(self) -> str:
        return "matrix" if isinstance(self.model, MatrixCompensator) else "seed"

    def estimate(self, theta1, theta2, load1, load2, *, threads: int | None = None, static: bool = False):
        """``(fx, fy, status)`` [N] for readings of a still arm: angles [rad], raw loads; vectorized.

        Status codes are :mod:`sailforce.estimate.estimator`'s; fx and fy are NaN for
        invalid and singular readings.  Large inputs run on ``threads``
        threads (default :data:`sailforce.estimate.estimator.THREADS`).
        A calibration with a dynamic term refuses, unless ``static``: the
        readings of a moving arm need the time and the term subtracted
        (:func:`sailforce.estimate.estimate_moving`).
        """
        if self.dynamics is not None and not static:
            raise InputError("this calibration carries a dynamic term, which a still-arm estimate would ignore: use "
                             "sailforce.estimate_moving(cal, cal.dynamics, t, theta1, theta2, load1, load2) with the "
                             "samples' times, or pass static=True for readings of a still arm")  # fmt: skip
        return estimate_calibrated(self, theta1, theta2, load1, load2, threads=threads)

    def with_offsets(self, offsets) -> Calibration:
        """A copy with new tare offsets (raw)."""
        return replace(self, offsets=(float(offsets[0]), float(offsets[1])))

    # -- file ---------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The JSON content, checksum included."""
        content = {
            "schema_version": SCHEMA_VERSION,
            "software": self.software,
            "created": self.created or _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            "data_sha256": self.data_sha256,
            "units": {"angles": "rad", "force": "N", "load": self.load_unit},
            "robot": {"l1": self.arm.l1, "l2": self.arm.l2, "l3": self.arm.l3, "l4": self.arm.l4},
            "offsets": list(map(float, self.offsets)),
            "capacity": list(map(float, self.capacity)),
            "delta_range": list(map(float, self.delta_range)),
            "load_range": [list(map(float, r)) for r in self.load_range],
            "model": _model_dict(self.model),
            "metrics": self.metrics,
        }
        if self.dynamics is not None:
            content["dynamics"] = _dynamics_dict(self.dynamics, self.dynamics_source)
        if self.multirate:
            content["adc"] = {"model": self.adc.model, "rate_Hz": self.adc.rate_Hz, "sinc_order": self.adc.sinc_order,
                              "noise_nV": self.adc.noise_nV, "simultaneous": self.adc.simultaneous,
                              "rate_tolerance": self.adc.rate_tolerance, "delay_s": self.adc_delay_s}  # fmt: skip
        if self.temperature is not None:
            t = self.temperature
            content["temperature"] = {"reference_C": t.reference_C, "zero_per_C": list(t.zero_per_C),
                                      "span_per_C": list(t.span_per_C)}  # fmt: skip
        content["checksum"] = checksum(content)
        return content

    def save(self, path: str | Path) -> None:
        """Write the calibration file atomically; refuses a calibration holding NaN or infinity."""
        try:
            text = json.dumps(self.to_dict(), indent=2, allow_nan=False)
        except ValueError:
            raise CalibrationFileError(
                f"{path}: the calibration holds a non-finite number (an overflow in the fit?), which a calibration "
                "file cannot carry; check that the loads are in a sensible unit (counts, mV/V or N)"
            ) from None
        with atomic_writer(path) as stream:
            stream.write(text + "\n")

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        """Read and validate a calibration file; :class:`CalibrationFileError` says what is wrong."""
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"), parse_float=_finite, parse_constant=_not_a_number)
        except FileNotFoundError:
            raise CalibrationFileError(f"{path}: no such calibration file") from None
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise CalibrationFileError(f"{path}: not a calibration file (invalid JSON: {exc})") from None
        except ValueError as exc:  # from the hooks: a number JSON may spell but a calibration cannot hold
            raise CalibrationFileError(f"{path}: not a calibration file ({exc})") from None
        return cls.from_dict(data, str(path))

    @classmethod
    def from_dict(cls, data: object, source: str = "calibration") -> Calibration:
        """Validate ``data`` (the parsed JSON) and build the calibration."""

        def fail(message: str) -> NoReturn:
            raise CalibrationFileError(f"{source}: {message}")

        if not isinstance(data, dict):
            fail("expected a JSON object")
        missing = [k for k in REQUIRED if k not in data]
        if missing:
            fail(f"missing field(s) {', '.join(missing)}")
        version = data["schema_version"]
        if type(version) is not int or version != SCHEMA_VERSION:  # true == 1 in Python, not in a file
            fail(f"schema_version {version!r} is not supported (this sailforce reads {SCHEMA_VERSION})")
        try:
            expected = checksum({k: v for k, v in data.items() if k != "checksum"})
        except (TypeError, ValueError) as exc:
            fail(f"content that a calibration file cannot hold ({exc})")
        if data["checksum"] != expected:
            fail("checksum does not match the content: the file was edited or corrupted; recalibrate or re-tare")
        try:
            arm = Arm(**{k: _number(data["robot"], k) for k in ("l1", "l2", "l3", "l4")})
        except (GeometryError, TypeError, KeyError) as exc:
            fail(f"robot: {exc}")
        units = data["units"]
        try:
            if not isinstance(units, dict):
                raise InputError("units must be an object")
            text = {k: check_text(k, data[k]) for k in ("created", "software", "data_sha256")}
            text["load"] = check_text("units.load", units.get("load", "raw"))
        except ValueError as exc:
            fail(str(exc))
        offsets = _pair(data, "offsets", fail)
        capacity = _pair(data, "capacity", fail)
        if min(capacity) <= 0:
            fail(f"capacity {capacity} must be positive")
        if max(map(abs, offsets + capacity)) > MAX_RAW:
            fail(f"offsets {offsets} and capacity {capacity} must lie within ±{MAX_RAW:g} raw units")
        delta_range = _pair(data, "delta_range", fail)
        if not 0.0 < delta_range[0] < delta_range[1] < math.pi and not -math.pi < delta_range[0] < delta_range[1] < 0.0:
            fail(f"delta_range {delta_range} rad must be increasing and inside (0, pi) or (-pi, 0)")
        load_range = data["load_range"]
        if not (isinstance(load_range, list) and len(load_range) == 2):
            fail("load_range must be [[min1, max1], [min2, max2]]")
        load_range = tuple(_pair({"r": r}, "r", fail) for r in load_range)
        for cell, (low, high) in enumerate(load_range, start=1):
            if not low <= high or max(abs(low), abs(high)) > MAX_RAW:
                fail(f"load_range of cell {cell} is [{low:g}, {high:g}]: expected min <= max, within ±{MAX_RAW:g}")
        model = _model_from(data["model"], arm, delta_range, fail)
        _check_sensing(model, capacity, delta_range, fail)
        dynamics = _dynamics_from(data["dynamics"], fail) if "dynamics" in data else None
        if dynamics is not None and data["dynamics"].get("source", "") not in ("", *DYNAMICS_SOURCES):
            fail(f"dynamics.source {data['dynamics'].get('source')!r}: expected one of {', '.join(DYNAMICS_SOURCES)}")
        adc, adc_delay = _adc_from(data["adc"], fail) if "adc" in data else (ADC(), 0.0)
        temperature = _temperature_from(data["temperature"], fail) if "temperature" in data else None
        return cls(arm=arm, model=model, offsets=offsets, capacity=capacity, delta_range=delta_range, adc=adc, adc_delay_s=adc_delay,
                   temperature=temperature,
                   load_range=load_range, load_unit=text["load"],
                   metrics=data["metrics"] if isinstance(data["metrics"], dict) else {},
                   data_sha256=text["data_sha256"], created=text["created"], software=text["software"],
                   dynamics=dynamics,
                   dynamics_source=str(data["dynamics"].get("source", "")) if dynamics else "")  # fmt: skip


def _adc_from(data: object, fail: Callable[[str], NoReturn]) -> tuple[ADC, float]:
    """The ``adc`` object: the ADC model's fields and the identified extra delay [s]."""
    if not isinstance(data, dict):
        fail("adc must be an object")
    try:
        model = data.get("model", "custom")
        if not isinstance(model, str) or not ADC_MODEL.match(model):
            raise InputError(f"adc.model = {model!r}: expected {ADC_MODEL_RULE}")
        adc = ADC(model=model, rate_Hz=_number(data, "rate_Hz"), sinc_order=data["sinc_order"],
                  noise_nV=_number(data, "noise_nV"), simultaneous=data["simultaneous"],
                  rate_tolerance=_number(data, "rate_tolerance"))  # fmt: skip
        delay = _number(data, "delay_s")
    except (KeyError, TypeError) as exc:
        fail(f"adc: {exc}")
    except InputError as exc:
        fail(str(exc))
    if adc.ideal or not abs(delay) <= adc.period_s:
        fail(f"adc: rate_Hz {adc.rate_Hz:g} and delay_s {delay:g}: expected a real ADC and a delay within one period")
    return adc, delay


#: A span coefficient beyond this per °C is no load cell's (the datasheets give 1e-5 to 1e-4): a corrupt file.
MAX_SPAN_PER_C = 0.01


def _temperature_from(data: object, fail: Callable[[str], NoReturn]) -> TemperatureCompensation:
    if not isinstance(data, dict) or not {"reference_C", "zero_per_C", "span_per_C"} <= data.keys():
        fail("temperature must be an object with reference_C, zero_per_C [raw/degC] and span_per_C [1/degC]")
    try:
        reference = _number(data, "reference_C")
    except TypeError as exc:
        fail(f"temperature: {exc}")
    zero, span = _pair(data, "zero_per_C", fail), _pair(data, "span_per_C", fail)
    if not -100.0 < reference < 200.0 or max(map(abs, span)) > MAX_SPAN_PER_C or max(map(abs, zero)) > MAX_RAW:
        fail(f"temperature: reference {reference:g} degC, span {span} per degC or zero {zero} per degC is not a load "
             f"cell's (span within +-{MAX_SPAN_PER_C:g} per degC)")  # fmt: skip
    return TemperatureCompensation(reference, zero, span)


def _check_sensing(model, capacity, delta_range, fail: Callable[[str], NoReturn]) -> None:
    """The sensing map must be invertible, and a full cell a plausible force, at every calibrated pose.

    M maps the hand force to the readings (s = M F, raw per N); its singular
    values bound what a full cell means: capacity / sigma_max is the smallest
    force that fills a cell.  Checked at ``theta2 = 0`` over the calibrated
    delta range, where the estimate is used without extrapolation.
    """
    delta = np.linspace(delta_range[0], delta_range[1], CHECK_POSES)
    with np.errstate(all="ignore"):
        m = model.sensing_matrix(delta, np.zeros_like(delta))
        sigma = np.linalg.svd(m, compute_uv=False) if np.all(np.isfinite(m)) else None
    if sigma is None or not np.all(np.isfinite(sigma)) or np.any(sigma[:, -1] <= sigma[:, 0] / MAX_CONDITION):
        fail("model: the sensing map is not invertible over the calibrated delta range (a zero or non-finite "
             "coefficient?); recalibrate")  # fmt: skip
    full_scale = min(capacity) / sigma[:, 0].max(), max(capacity) / sigma[:, -1].min()
    low, high = FULL_SCALE_FORCE_N
    if full_scale[0] < low or full_scale[1] > high:
        fail(f"model and capacity: a full cell stands for {full_scale[0]:.3g} to {full_scale[1]:.3g} N at the hand, "
             f"outside {low:g} .. {high:g} N; the numbers are not a calibration of this arm's cells")  # fmt: skip


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise InputError(f"the number {text} is out of range")
    return value


def _not_a_number(text: str) -> float:
    raise InputError(f"{text} is not a number a calibration file may hold")


def checksum(content: dict) -> str:
    """SHA-256 of the canonical JSON of ``content`` (sorted keys, no whitespace)."""
    canonical = json.dumps(content, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()


def _number(mapping, key) -> float:
    value = mapping[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise TypeError(f"{key} = {value!r} is not a finite number")
    return float(value)


def _pair(data: dict, key: str, fail: Callable[[str], NoReturn]) -> tuple[float, float]:
    value = data[key]
    try:
        if not (isinstance(value, list) and len(value) == 2):
            raise TypeError
        return (_number(value, 0), _number(value, 1))
    except TypeError:
        fail(f"{key} = {value!r}: expected two finite numbers")


def _dynamics_dict(term: DynamicTerm, source: str) -> dict:
    return {"columns": list(term.names), "values": list(term.values), "combinations": list(term.combinations),
            "differentiator": {"window_s": term.differentiator.window_s, "order": term.differentiator.order},
            "source": source}  # fmt: skip


def _dynamics_from(data: object, fail: Callable[[str], NoReturn]) -> DynamicTerm:
    if not isinstance(data, dict):
        fail("dynamics must be an object")
    columns, values = data.get("columns"), data.get("values")
    if not (isinstance(columns, list) and isinstance(values, list) and len(columns) == len(values) and columns):
        fail("dynamics.columns and dynamics.values must be lists of equal length")
    unknown = [c for c in columns if c not in PARAMETERS]
    if unknown:
        fail(f"dynamics.columns: unknown parameter(s) {', '.join(map(str, unknown))}")
    try:
        numbers = [_number(values, i) for i in range(len(values))]
        spec = data.get("differentiator", {})
        differentiator = Differentiator(_number(spec, "window_s"), int(_number(spec, "order")))
    except (TypeError, KeyError, SailError) as exc:
        fail(f"dynamics: {exc}")
    combinations = data.get("combinations", [])
    if not (isinstance(combinations, list) and all(isinstance(c, str) for c in combinations)):
        fail("dynamics.combinations must be a list of text")
    return DynamicTerm(tuple(PARAMETERS.index(c) for c in columns), tuple(numbers), differentiator, tuple(combinations))


def _model_dict(model) -> dict:
    if isinstance(model, MatrixCompensator):
        return {"kind": "matrix", "coefficients": np.asarray(model.coefficients).tolist(),
                "delta_range": list(model.delta_range), "cv_rmse_N": list(model.cv_rmse)}  # fmt: skip
    return {"kind": "seed", "amplitude": [list(p.coefficients) for p in model.amplitude],
            "phase_deg": [list(p.coefficients) for p in model.phase_deg],
            "delta_range": list(model.delta_range)}  # fmt: skip


def _model_from(data: object, arm: Arm, delta_range, fail: Callable[[str], NoReturn]):
    if not isinstance(data, dict) or data.get("kind") not in ("seed", "matrix"):
        fail("model.kind must be 'seed' or 'matrix'")
    model_range = _pair(data, "delta_range", fail) if "delta_range" in data else delta_range
    if data["kind"] == "matrix":
        try:
            c = np.asarray(data["coefficients"], dtype=float)
        except (KeyError, TypeError, ValueError):
            fail("model.coefficients must be an (order + 1, 2, 2) array of numbers")
        if c.ndim != 3 or c.shape[1:] != (2, 2) or c.shape[0] < 1 or not np.all(np.isfinite(c)):
            fail(f"model.coefficients must be a finite (order + 1, 2, 2) array, got shape {c.shape}")
        if not model_range[0] < model_range[1]:
            fail(f"model.delta_range {model_range} must be increasing")
        return MatrixCompensator(arm, c, model_range)
    fits = {}
    for key in ("amplitude", "phase_deg"):
        polys = data.get(key)
        if not (isinstance(polys, list) and len(polys) == 2 and all(isinstance(p, list) and p for p in polys)):
            fail(f"model.{key} must be two lists of polynomial coefficients")
        try:
            fits[key] = tuple(PolynomialFit(len(p) - 1, tuple(_number(p, i) for i in range(len(p))),
                                            math.nan, math.nan, "cv", math.nan, True) for p in polys)  # fmt: skip
        except TypeError as exc:
            fail(f"model.{key}: {exc}")
    (a1, a2), (p1, p2) = fits["amplitude"], fits["phase_deg"]
    return AmplitudePhaseCompensator(arm, (a1, a2), (p1, p2), model_range)
