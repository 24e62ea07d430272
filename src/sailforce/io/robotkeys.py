"""Robot-file keys as dotted paths: read and change one value of a robot.

``links.l1``, ``loadcells.position``, ``joints.P1.stiffness``,
``materials.links.E`` ... name the same values as the robot file's tables
(``sail robot init`` writes them all).  ``sail identify`` frees such keys and
``sail design --sweep`` varies them; both go through :func:`with_keys`, which
rebuilds the robot through the robot file's own validation, so a value the
file would refuse is refused here too, naming the key.

Two keys move together: ``links.l2`` also sets ``links.l4`` (the parallelogram
needs l4 = l2).  A per-joint key such as ``joints.P1.stiffness`` on a robot
without a ``[joints.P1]`` table starts that table from the shared ``[joints]``;
likewise a per-link key, ``sections.l3.depth`` from ``[sections]`` and
``materials.l3.E`` from ``[materials.links]``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

from ..errors import RobotFileError
from ..robot import JOINT_NAMES, LINK_NAMES, Robot
from .robotfile import SECTION_KEYS, robot_data, robot_from_data

#: Per-body tables that start, when absent, from a shared table: (section, names) -> the shared table's path
_SHARED = {"joints": (JOINT_NAMES, ("joints",)), "sections": (LINK_NAMES, ("sections",)),
           "materials": (LINK_NAMES, ("materials", "links"))}  # fmt: skip


def _shared(data: dict[str, Any], section: str) -> dict[str, Any]:
    """The shared table a per-body table of ``section`` starts from (its plain values only)."""
    node = data
    for part in _SHARED[section][1]:
        node = node[part]
    keep = SECTION_KEYS if section == "sections" else ("model", "stiffness") if section == "joints" else tuple(node)
    return {k: node[k] for k in keep}


def _per_body(parts: list[str]) -> bool:
    """True for a three-part key on a per-body table: ``joints.P1.stiffness``, ``sections.l3.depth`` ..."""
    return len(parts) == 3 and parts[0] in _SHARED and parts[1] in _SHARED[parts[0]][0]


def _leaves(table: Mapping[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    for key, value in table.items():
        if isinstance(value, Mapping):
            yield from _leaves(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


def _keyed_data(robot: Robot) -> dict[str, Any]:
    """The robot file's tables with every ``adc.*`` key, so that a sweep may set one on a robot without ``[adc]``."""
    data = robot_data(robot)
    adc = robot.adc
    data["adc"] = {"model": adc.model, "rate_Hz": adc.rate_Hz, "sinc_order": adc.sinc_order, "noise_nV": adc.noise_nV,
                   "simultaneous": adc.simultaneous, "rate_tolerance": adc.rate_tolerance}  # fmt: skip
    return data


def _adc_table(robot: Robot, values: Mapping[str, Any]) -> dict[str, Any]:
    """The ``[adc]`` table after setting ``adc.*`` keys: a new model starts from its preset, other keys override it."""
    own = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("adc.")}
    if "model" in own:
        return own
    base = robot_data(robot).get("adc", {"model": robot.adc.model})
    return {**base, **own}


def robot_keys(robot: Robot, *, numeric: bool = False) -> tuple[str, ...]:
    """Every key of ``robot`` (``numeric``: only those holding numbers), per-joint keys included."""
    data = _keyed_data(robot)
    for section, (names, _) in _SHARED.items():
        for name in names:
            data[section].setdefault(name, _shared(data, section))
    return tuple(key for key, value in _leaves(data) if not numeric or not isinstance(value, (str, bool)))


def _unknown(robot: Robot, key: str) -> RobotFileError:
    keys = robot_keys(robot)
    section = key.split(".")[0]
    near = [k for k in keys if k.split(".")[0] == section] or keys
    return RobotFileError(f"unknown robot key {key!r}: expected one of {', '.join(near)}")


def get_key(robot: Robot, key: str) -> Any:
    """The value of ``key`` on ``robot`` (a per-joint or per-link key falls back to the shared table)."""
    return _get(_keyed_data(robot), robot, key)


def _get(keyed: dict[str, Any], robot: Robot, key: str) -> Any:
    """:func:`get_key` on ``robot``'s :func:`_keyed_data` ``keyed``, made once for many keys."""
    node: Any = keyed
    parts = key.split(".")
    if _per_body(parts) and parts[1] not in node[parts[0]]:
        parts = [*_SHARED[parts[0]][1], parts[2]]
    for part in parts:
        if not isinstance(node, dict) or part not in node:
            raise _unknown(robot, key)
        node = node[part]
    if isinstance(node, dict):
        raise _unknown(robot, key)
    return node


def with_keys(robot: Robot, values: Mapping[str, Any]) -> Robot:
    """A copy of ``robot`` with each ``key = value`` set, validated as a robot file would be."""
    data = _keyed_data(robot)
    edited = robot_data(robot)  # a second, independent copy (robot_data builds its tables afresh): cheaper than deepcopy
    for key, value in values.items():
        _get(data, robot, key)  # refuses unknown keys by name
        if key.startswith("adc."):
            edited["adc"] = _adc_table(robot, values)
            continue
        parts = key.split(".")
        node = edited
        for i, part in enumerate(parts[:-1]):
            if part not in node and i == 1 and _per_body(parts):
                node[part] = _shared(data, parts[0])
            node = node[part]
        node[parts[-1]] = value
        if key == "links.l2":
            edited["links"]["l4"] = value
    try:
        return robot_from_data(edited, "<" + ", ".join(f"{k} = {v!r}" for k, v in values.items()) + ">")
    except RobotFileError as exc:
        raise RobotFileError(str(exc).replace(">: [", ">: the robot file's [", 1)) from None


#: What an arm that a hand holds can plausibly have, by the last part of a key: (low, high, unit).  A value
#: outside is accepted, with a warning: a section 1e6 m deep or a 1e300 kg handle is a unit slip, not a design.
PLAUSIBLE = {
    "depth": (1e-4, 0.5, "m"), "thickness": (1e-4, 0.5, "m"), "length": (1e-3, 0.5, "m"),
    "mass": (0.0, 50.0, "kg"), "capacity_kg": (0.01, 1e4, "kg"), "rated_deflection": (1e-7, 0.05, "m"),
    "E": (1e8, 1.5e12, "Pa"), "rho": (100.0, 25_000.0, "kg/m^3"), "yield_strength": (1e6, 1e10, "Pa"),
    "stiffness": (0.0, 1e12, "N m/rad"), "noise_mV_V": (0.0, 1.0, "mV/V"), "rated_output_mV_V": (0.01, 100.0, "mV/V"),
}  # fmt: skip


def plausibility_warnings(robot: Robot) -> list[str]:
    """One line per value outside :data:`PLAUSIBLE`, naming the key, its value and the range."""
    warnings = []
    for key, value in _leaves(robot_data(robot)):  # the file's own tables: no per-link copy of a shared value
        bounds = PLAUSIBLE.get(key.rsplit(".", 1)[-1])
        if bounds is not None and not isinstance(value, str) and not bounds[0] <= value <= bounds[1]:
            low, high, unit = bounds
            warnings.append(f"{key} = {value:g} {unit} is outside {low:g} .. {high:g} {unit}, implausible for an arm "
                            "a hand holds; check its unit")  # fmt: skip
    return warnings
