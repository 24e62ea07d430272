"""Robot files: a TOML description of one SAIL arm.

A file needs only a ``[links]`` table; every other section has defaults, so
a file holding only ``[links]`` stays valid as sections are added.  Unknown
sections and keys are refused, because a misspelt key silently falling back
to a default is the kind of error that costs a lab a week.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .arm import Arm
from .errors import GeometryError, RobotFileError

LINK_KEYS = ("l1", "l2", "l3", "l4")
KNOWN_SECTIONS = ("links",)

TEMPLATE = """\
# sailforce robot file: one SAIL parallelogram arm.
# Units are SI throughout (metres).  Angles are measured counter-clockwise from +x.
#
#   P2 o-----------o P3 ------------o A   (end effector)
#      |    l1     |
#   l2 |           | l4 = l2, parallel to l2
#      |           |
#    B o-----------o P1
#           l1
# l3 is the whole upper bar, from P2 through P3 to A, parallel to l1.
#
# The motors at B drive l1 (angle theta1) and l2 (angle theta2).
# SAIL puts one single-axis load cell in the middle of l1 and of l2.

[links]
l1 = {l1}   # m, B to P1, driven by theta1
l2 = {l2}   # m, B to P2, driven by theta2
l3 = {l3}  # m, P2 through P3 to the end effector A; must exceed l1 (|P2 P3| = l1)
l4 = {l4}   # m, P1 to P3; must equal l2
"""


@dataclass(frozen=True)
class RobotFile:
    """A parsed robot file."""

    path: Path
    arm: Arm


def template(arm: Arm | None = None) -> str:
    """The commented robot-file text for ``arm`` (the default robot if None)."""
    arm = arm or Arm()
    return TEMPLATE.format(l1=arm.l1, l2=arm.l2, l3=arm.l3, l4=arm.l4)


def write_template(path: str | Path, *, overwrite: bool = False) -> Path:
    """Write :func:`template` to ``path``; refuse to replace an existing file unless asked."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise RobotFileError(f"{path}: already exists; pass --force to overwrite it")
    try:
        path.write_text(template(), encoding="utf-8")
    except OSError as exc:
        raise RobotFileError(f"{path}: cannot write ({exc.strerror})") from None
    return path


def load_robot_file(path: str | Path) -> RobotFile:
    """Parse and validate a robot file; every problem names the file and the key."""
    path = Path(path)
    try:
        with path.open("rb") as handle:
            data = tomllib.load(handle)
    except FileNotFoundError:
        raise RobotFileError(f"{path}: no such file; `sail robot init {path}` writes a template") from None
    except OSError as exc:
        raise RobotFileError(f"{path}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise RobotFileError(f"{path}: not valid TOML: {exc}") from None
    return RobotFile(path=path, arm=_parse_links(path, data))


def _parse_links(path: Path, data: dict[str, Any]) -> Arm:
    unknown = sorted(set(data) - set(KNOWN_SECTIONS))
    if unknown:
        raise RobotFileError(
            f"{path}: unknown section(s) {', '.join(unknown)}; known: {', '.join(KNOWN_SECTIONS)}"
        )
    links = data.get("links")
    if not isinstance(links, dict):
        raise RobotFileError(f"{path}: missing the [links] table with keys {', '.join(LINK_KEYS)}")
    extra = sorted(set(links) - set(LINK_KEYS))
    if extra:
        raise RobotFileError(f"{path}: [links] has unknown key(s) {', '.join(extra)}; expected {', '.join(LINK_KEYS)}")
    missing = [key for key in LINK_KEYS if key not in links]
    if missing:
        raise RobotFileError(f"{path}: [links] is missing {', '.join(missing)} (metres)")
    for key in LINK_KEYS:
        value = links[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise RobotFileError(f"{path}: [links] {key} = {value!r}: expected a length in metres")
    try:
        return Arm(**{key: links[key] for key in LINK_KEYS})
    except GeometryError as exc:
        raise RobotFileError(f"{path}: [links] {exc}") from None
