"""Robot-file keys as dotted paths: read and change one value of a robot.

``links.l1``, ``loadcells.position``, ``joints.P1.stiffness``,
``materials.links.E`` ... name the same values as the robot file's tables
(``sail robot init`` writes them all).  ``sail identify`` frees such keys and
``sail design --sweep`` varies them; both go through :func:`with_keys`, which
rebuilds the robot through the robot file's own validation, so a value the
file would refuse is refused here too, naming the key.

Two keys move together: ``links.l2`` also sets ``links.l4`` (the parallelogram
needs l4 = l2), and a per-joint key such as ``joints.P1.stiffness`` on a robot
without a ``[joints.P1]`` table starts that table from the shared ``[joints]``.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Mapping
from typing import Any

from ..errors import RobotFileError
from ..robot import JOINT_NAMES, Robot
from .robotfile import robot_data, robot_from_data


def _leaves(table: Mapping[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    for key, value in table.items():
        if isinstance(value, Mapping):
            yield from _leaves(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


def robot_keys(robot: Robot, *, numeric: bool = False) -> tuple[str, ...]:
    """Every key of ``robot`` (``numeric``: only those holding numbers), per-joint keys included."""
    data = robot_data(robot)
    for name in JOINT_NAMES:
        data["joints"].setdefault(name, {"model": robot.joints.model, "stiffness": robot.joints.stiffness})
    return tuple(key for key, value in _leaves(data) if not numeric or not isinstance(value, str))


def _unknown(robot: Robot, key: str) -> RobotFileError:
    keys = robot_keys(robot)
    section = key.split(".")[0]
    near = [k for k in keys if k.split(".")[0] == section] or keys
    return RobotFileError(f"unknown robot key {key!r}: expected one of {', '.join(near)}")


def get_key(robot: Robot, key: str) -> Any:
    """The value of ``key`` on ``robot`` (a per-joint key falls back to the shared joint)."""
    node: Any = robot_data(robot)
    parts = key.split(".")
    if len(parts) == 3 and parts[0] == "joints" and parts[1] in JOINT_NAMES and parts[1] not in node["joints"]:
        parts = ["joints", parts[2]]
    for part in parts:
        if not isinstance(node, dict) or part not in node:
            raise _unknown(robot, key)
        node = node[part]
    if isinstance(node, dict):
        raise _unknown(robot, key)
    return node


def with_keys(robot: Robot, values: Mapping[str, Any]) -> Robot:
    """A copy of ``robot`` with each ``key = value`` set, validated as a robot file would be."""
    data = robot_data(robot)
    edited = copy.deepcopy(data)
    for key, value in values.items():
        get_key(robot, key)  # refuses unknown keys by name
        parts = key.split(".")
        node = edited
        for i, part in enumerate(parts[:-1]):
            if part not in node and i == 1 and parts[0] == "joints":
                node[part] = {"model": data["joints"]["model"], "stiffness": data["joints"]["stiffness"]}
            node = node[part]
        node[parts[-1]] = value
        if key == "links.l2":
            edited["links"]["l4"] = value
    try:
        return robot_from_data(edited, "<" + ", ".join(f"{k} = {v!r}" for k, v in values.items()) + ">")
    except RobotFileError as exc:
        raise RobotFileError(str(exc).replace(">: [", ">: the robot file's [", 1)) from None
