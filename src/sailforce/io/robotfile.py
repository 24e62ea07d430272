"""Robot files: a TOML description of one SAIL arm.

A file needs only a ``[links]`` table; every other section has defaults, so
a file holding only ``[links]`` stays valid as sections are added.  Unknown
sections and keys are refused, because a misspelt key silently falling back
to a default is the kind of error that costs a lab a week.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..adc import ADC, ADC_KEYS, PRESETS, adc_from_table
from ..arm import Arm
from ..errors import GeometryError, RobotFileError, SailError
from ..materials import RectangularSection
from ..robot import JOINT_NAMES, LINK_NAMES, Joint, Joints, LinkBodies, LinkBody, Robot
from .files import atomic_writer

LINK_KEYS = LINK_NAMES
SECTION_KEYS = ("depth", "thickness")
MATERIAL_KEYS = ("E", "nu", "rho", "yield_strength")
LOADCELL_KEYS = ("capacity_kg", "rated_deflection", "length", "position", "depth", "thickness",
                 "rated_output_mV_V", "crosstalk_axial", "crosstalk_moment",
                 "compliance", "compliance_vv", "compliance_vm", "compliance_mm", "noise_mV_V", "reading")  # fmt: skip
#: Keys whose value is true or false.
BOOL_KEYS = ("simultaneous",)
#: Keys whose value is a quoted name rather than a number.
NAME_KEYS = ("model", "compliance", "reading")
#: Each optional section and the keys it may hold; ``links`` is required.
SECTIONS = {
    "links": LINK_KEYS,
    "sections": (*SECTION_KEYS, *LINK_NAMES),
    "materials": ("links", "loadcells", *LINK_NAMES),
    "loadcells": LOADCELL_KEYS,
    "joints": ("model", "stiffness", *JOINT_NAMES),
    "motors": ("model", "stiffness"),
    "handle": ("mass", "position"),
    "plane": ("tilt_deg", "axis_deg"),
    "adc": ADC_KEYS,
}
KNOWN_SECTIONS = tuple(SECTIONS)

TEMPLATE = """\
# sailforce robot file: one SAIL parallelogram arm.
# Units are SI throughout (m, N, Pa, kg).  Angles are counter-clockwise from +x.
# Only [links] is required; every other section may be left out, and each key
# left out keeps the default shown here.
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

[sections]          # rectangular cross-section of the four links
depth = {depth}     # m, in the plane of motion (bending depth)
thickness = {thickness}  # m, out of the plane
# [sections.l3]     # optional: one link's own section, overriding [sections] (also l1, l2, l4)
# depth = 0.03
{section_overrides}
[materials.links]   # seed Table 2: plain carbon steel
E = {steel_E:g}            # Pa
nu = {steel_nu}              # -
rho = {steel_rho:g}            # kg/m^3
yield_strength = {steel_yield:g}  # Pa

# [materials.l4]    # optional: one link's own material, overriding [materials.links] (also l1, l2, l3)
# rho = 2700
{material_overrides}
[materials.loadcells]  # seed Table 3: 7075-T6 aluminium
E = {al_E:g}
nu = {al_nu}
rho = {al_rho:g}
yield_strength = {al_yield:g}

[loadcells]         # MT1041-like single-axis bending-beam cells, one per driven link
capacity_kg = {capacity_kg:g}        # rated capacity
rated_deflection = {rated_deflection:g}  # m, far-face deflection at capacity (sets the cell's bending stiffness)
length = {length:g}            # m, the gap in the link that the cell bridges
position = {position:g}            # centre of the gap, as a fraction of l1 (and of l2) from B
depth = {cell_depth:g}             # m, solid block section (axial and shear stiffness, nominal stress)
thickness = {cell_thickness:g}
rated_output_mV_V = {rated_output:g}    # bridge output at capacity
crosstalk_axial = {xa:g}       # bridge output per rated output, per unit (axial force / capacity)
crosstalk_moment = {xm:g}      # ... per unit (moment / (capacity x length))
compliance = "{compliance}"  # bending compliance: "datasheet" (beam fitted to rated_deflection), "block" (the solid
                        # block's own E I, as a SolidWorks part) or "matrix" (the three entries below)
compliance_vv = {cvv:g}         # m/N, far-face deflection per shear, near face clamped ("matrix" only)
compliance_vm = {cvm:g}         # 1/N, far-face deflection per moment = rotation per shear
compliance_mm = {cmm:g}         # 1/(N m), far-face rotation per moment
noise_mV_V = {noise:g}        # 1-sigma reading noise (ADC and bridge), for sail design's resolution maps
{reading_line}

[joints]            # the passive joints P1, P2, P3
model = "{joints}"       # "pin" (ideal revolute), "bonded" (rigid, SolidWorks' default contact) or "spring"
stiffness = {joint_k:g}    # N m/rad, used by "spring"
# [joints.P1]       # optional: one joint's own model and stiffness, overriding [joints] (also P2, P3)
# model = "spring"
# stiffness = 170
{joint_overrides}

[motors]            # the motors at B
model = "{motors}"    # "locked" (clamped) or "gearbox" (torsional spring to ground)
stiffness = {motor_k:g}    # N m/rad, used by "gearbox"

[handle]            # what the patient holds at A; its inertia loads the cells while the arm moves
mass = {handle_mass:g}            # kg
position = {handle_position:g}        # along l3 from P2, as a fraction of l3 (1 = at A)

[plane]             # the plane of motion; tilted, gravity has a component in it that loads the cells
tilt_deg = {tilt:g}        # angle from horizontal
axis_deg = {axis:g}      # direction in the plane (CCW from +x) that the in-plane gravity points to
{adc_block}"""


@dataclass(frozen=True)
class RobotFile:
    """A parsed robot file."""

    path: Path
    robot: Robot

    @property
    def arm(self) -> Arm:
        return self.robot.arm


def template(robot: Robot | None = None) -> str:
    """The commented robot-file text for ``robot`` (the default robot if None)."""
    r = robot or Robot()
    cell, steel, al = r.loadcell, r.link_material, r.loadcell.material
    return TEMPLATE.format(
        l1=r.arm.l1, l2=r.arm.l2, l3=r.arm.l3, l4=r.arm.l4,
        depth=r.link_section.depth, thickness=r.link_section.thickness,
        steel_E=steel.E, steel_nu=steel.nu, steel_rho=steel.rho, steel_yield=steel.yield_strength,
        al_E=al.E, al_nu=al.nu, al_rho=al.rho, al_yield=al.yield_strength,
        capacity_kg=cell.capacity_kg, rated_deflection=cell.rated_deflection, length=cell.length,
        position=cell.position, cell_depth=cell.block.depth, cell_thickness=cell.block.thickness,
        rated_output=cell.rated_output_mV_V, xa=cell.crosstalk_axial, xm=cell.crosstalk_moment,
        compliance=cell.compliance, cvv=cell.compliance_vv, cvm=cell.compliance_vm, cmm=cell.compliance_mm, noise=cell.noise_mV_V,
        reading_line=_reading_line(cell.reading),
        section_overrides=_link_overrides(r, "sections"), material_overrides=_link_overrides(r, "materials"),
        joints=r.joints.model, joint_k=r.joints.stiffness, joint_overrides=_joint_overrides(r.joints),
        motors=r.motors.model, motor_k=r.motors.stiffness,
        handle_mass=r.handle.mass, handle_position=r.handle.position, tilt=r.plane.tilt_deg, axis=r.plane.axis_deg,
        adc_block=_adc_block(r.adc),
    )  # fmt: skip


def _adc_block(adc: ADC) -> str:
    """The ``[adc]`` table when the robot has one, else a comment that shows how to state it."""
    models = ", ".join(f'"{name}"' for name in PRESETS)
    if adc == ADC():
        return (f'\n# [adc]             # the cells\' ADC (docs/reference/adc.md); unset: the ideal sensor, a reading at every tick\n'
                f'# model = "hx711-80"  # a preset: {models}\n'
                "# rate_Hz = 80       # or explicit keys, overriding the preset's: conversions per second,\n"
                "# sinc_order = 4     # the sinc filter's order (settles in sinc_order conversions),\n"
                "# noise_nV = 90      # input noise rms at that rate, simultaneous = true for one two-channel chip\n")
    preset = PRESETS.get(adc.model)
    lines = ["", "[adc]             # the cells' ADC (docs/reference/adc.md)"]
    if preset is not None:
        lines.append(f'model = "{adc.model}"  # one of {models}')
    else:
        for key in ("rate_Hz", "sinc_order", "noise_nV", "rate_tolerance"):
            lines.append(f"{key} = {getattr(adc, key):g}")
        lines.append(f"simultaneous = {'true' if adc.simultaneous else 'false'}")
    return "\n".join(lines) + "\n"


def _reading_line(reading: str) -> str:
    """The ``reading`` key: set when the file states it (sail identify writes it), a comment otherwise."""
    what = '# "deflection" (m, far face) or "bridge" (mV/V): what the cells read; every command honours it'
    return f'reading = "{reading}"  {what}' if reading else f'# reading = "bridge"  {what} (unset: each its own default)'


def _link_overrides(robot: Robot, section: str) -> str:
    """``[sections.l3]`` or ``[materials.l3]`` ... tables for the links that have their own."""
    tables = []
    for name, values in robot_data(robot)[section].items():
        if name in LINK_NAMES:
            body = "\n".join(f"{key} = {value!r}" for key, value in values.items())
            tables.append(f"[{section}.{name}]\n{body}\n")
    return "\n".join(tables)


def _joint_overrides(joints: Joints) -> str:
    """``[joints.P1]`` ... tables for the joints that have their own model."""
    tables = []
    for name in JOINT_NAMES:
        own = getattr(joints, name)
        if own is not None:
            tables.append(f'[joints.{name}]\nmodel = "{own.model}"\nstiffness = {own.stiffness:g}\n')
    return "\n".join(tables)


def write_template(path: str | Path, *, overwrite: bool = False) -> Path:
    """Write :func:`template` to ``path``; refuse to replace an existing file unless asked."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise RobotFileError(f"{path}: already exists; pass --force to overwrite it")
    try:
        with atomic_writer(path) as stream:
            stream.write(template())
    except OSError as exc:
        raise RobotFileError(f"{path}: cannot write ({exc.strerror})") from None
    return path


def load_arm(path: str | Path) -> Arm:
    """The :class:`Arm` of a robot file's ``[links]`` table (see ``sail robot init``)."""
    return load_robot_file(path).arm


def load_robot_file(path: str | Path) -> RobotFile:
    """Parse and validate a robot file; every problem names the file and the key."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise RobotFileError(f"{path}: no such file; `sail robot init {path}` writes a template") from None
    except OSError as exc:
        raise RobotFileError(f"{path}: cannot read ({exc.strerror})") from None
    try:
        data = tomllib.loads(raw.removeprefix(b"\xef\xbb\xbf").decode("utf-8"))  # editors may add a byte-order mark
    except RecursionError:
        raise RobotFileError(f"{path}: nested too deeply to be a robot file (arrays or tables within each other "
                             "thousands of levels down)") from None
    except UnicodeDecodeError as exc:
        raise RobotFileError(f"{path}: not a text file (byte {exc.start} is not UTF-8); expected a TOML robot file") from None
    except tomllib.TOMLDecodeError as exc:
        raise RobotFileError(f"{path}: not valid TOML: {exc}") from None
    return RobotFile(path=path, robot=robot_from_data(data, path))


def robot_from_data(data: dict[str, Any], source: str | Path = "<robot>") -> Robot:
    """The :class:`Robot` of a robot file's parsed TOML ``data``; errors name ``source`` and the key."""
    path = Path(source)
    unknown = sorted(set(data) - set(KNOWN_SECTIONS))
    if unknown:
        raise RobotFileError(
            f"{path}: unknown section(s) {', '.join(unknown)}; known: {', '.join(KNOWN_SECTIONS)}"
        )
    arm = _parse_links(path, data)
    try:
        return _parse_structure(path, data, arm)
    except GeometryError as exc:
        raise RobotFileError(f"{path}: {exc}") from None


def robot_data(robot: Robot) -> dict[str, Any]:
    """The robot file's tables for ``robot`` at full precision: :func:`robot_from_data` inverts it."""
    cell, arm = robot.loadcell, robot.arm
    material = lambda m: {"E": m.E, "nu": m.nu, "rho": m.rho, "yield_strength": m.yield_strength}
    joints: dict[str, Any] = {"model": robot.joints.model, "stiffness": robot.joints.stiffness}
    for name in JOINT_NAMES:
        own = getattr(robot.joints, name)
        if own is not None:
            joints[name] = {"model": own.model, "stiffness": own.stiffness}
    sections: dict[str, Any] = {"depth": robot.link_section.depth, "thickness": robot.link_section.thickness}
    materials: dict[str, Any] = {"links": material(robot.link_material), "loadcells": material(cell.material)}
    for name in LINK_NAMES:
        own = getattr(robot.bodies, name)
        if own is not None and own.section is not None:
            sections[name] = {"depth": own.section.depth, "thickness": own.section.thickness}
        if own is not None and own.material is not None:
            materials[name] = material(own.material)
    return {
        "links": {"l1": arm.l1, "l2": arm.l2, "l3": arm.l3, "l4": arm.l4},
        "sections": sections,
        "materials": materials,
        "loadcells": {**{key: getattr(cell, key) for key in LOADCELL_KEYS if key not in ("depth", "thickness")},
                      "depth": cell.block.depth, "thickness": cell.block.thickness},
        "joints": joints,
        "motors": {"model": robot.motors.model, "stiffness": robot.motors.stiffness},
        "handle": {"mass": robot.handle.mass, "position": robot.handle.position},
        "plane": {"tilt_deg": robot.plane.tilt_deg, "axis_deg": robot.plane.axis_deg},
        **({"adc": _adc_data(robot.adc)} if robot.adc != ADC() else {}),  # the ideal sensor: no table, as before
    }  # fmt: skip


def _adc_data(adc: ADC) -> dict[str, Any]:
    if PRESETS.get(adc.model) == adc:
        return {"model": adc.model}
    return {"rate_Hz": adc.rate_Hz, "sinc_order": adc.sinc_order, "noise_nV": adc.noise_nV,
            "simultaneous": adc.simultaneous, "rate_tolerance": adc.rate_tolerance}  # fmt: skip


def _table(path: Path, data: dict[str, Any], name: str, keys: tuple[str, ...] | None = None, *,
           parent: str = "") -> dict[str, Any]:
    """An optional table, checked for unknown keys and non-numeric values (``parent``: its section, for messages)."""
    table = data.get(name, {})
    name = f"{parent}.{name}" if parent else name
    if not isinstance(table, dict):
        raise RobotFileError(f"{path}: [{name}] must be a table")
    allowed = keys if keys is not None else SECTIONS[name.split(".")[0]]
    extra = sorted(set(table) - set(allowed))
    if extra:
        raise RobotFileError(f"{path}: [{name}] has unknown key(s) {', '.join(extra)}; expected {', '.join(allowed)}")
    for key, value in table.items():
        if key in NAME_KEYS or isinstance(value, dict) or (key in BOOL_KEYS and isinstance(value, bool)):
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise RobotFileError(f"{path}: [{name}] {key} = {value!r}: expected a number")
    return table


def _parse_structure(path: Path, data: dict[str, Any], arm: Arm) -> Robot:
    default = Robot(arm=arm)
    sections = _table(path, data, "sections")
    materials = _table(path, data, "materials")
    link_mat = _table(path, materials, "links", MATERIAL_KEYS, parent="materials") if "links" in materials else {}
    link_section = replace(default.link_section, **{k: v for k, v in sections.items() if k in SECTION_KEYS})
    link_material = replace(default.link_material, **link_mat)
    bodies = {}
    for name in LINK_NAMES:
        own_section = _table(path, sections, name, SECTION_KEYS, parent="sections") if name in sections else None
        own_material = _table(path, materials, name, MATERIAL_KEYS, parent="materials") if name in materials else None
        if own_section is not None or own_material is not None:
            bodies[name] = LinkBody(
                None if own_section is None else replace(link_section, **own_section),
                None if own_material is None else replace(link_material, name=f"{link_material.name}, {name}'s own", **own_material),
            )  # fmt: skip
    cell_mat = _table(path, materials, "loadcells", MATERIAL_KEYS, parent="materials") if "loadcells" in materials else {}
    cells = _table(path, data, "loadcells")
    joints = _table(path, data, "joints")
    motors = _table(path, data, "motors")
    handle = _table(path, data, "handle")
    plane = _table(path, data, "plane")
    adc_table = _table(path, data, "adc")
    if "model" in adc_table and not isinstance(adc_table["model"], str):
        raise RobotFileError(f"{path}: [adc] model = {adc_table['model']!r}: expected a quoted name")
    per_joint = {name: _table(path, joints, name, ("model", "stiffness"), parent="joints") for name in JOINT_NAMES if name in joints}
    shared = {k: v for k, v in joints.items() if k not in JOINT_NAMES}
    for name, table in (("joints", shared), ("motors", motors), ("loadcells", cells),
                        *((f"joints.{n}", j) for n, j in per_joint.items())):  # fmt: skip
        for key in NAME_KEYS:
            if key in table and not isinstance(table[key], str):
                raise RobotFileError(f"{path}: [{name}] {key} = {table[key]!r}: expected a quoted name")

    cell_default = default.loadcell
    cell_block = RectangularSection(
        cells.get("depth", cell_default.block.depth), cells.get("thickness", cell_default.block.thickness)
    )
    cell_fields = {k: cells[k] for k in LOADCELL_KEYS if k in cells and k not in ("depth", "thickness")}
    return Robot(
        arm=arm,
        link_section=link_section,
        link_material=link_material,
        loadcell=replace(
            cell_default, block=cell_block, material=replace(cell_default.material, **cell_mat), **cell_fields
        ),
        joints=Joints(shared.get("model", default.joints.model), shared.get("stiffness", default.joints.stiffness),
                      *(Joint(**per_joint[name]) if name in per_joint else None for name in JOINT_NAMES)),
        motors=replace(default.motors, **motors),
        handle=replace(default.handle, **handle),
        plane=replace(default.plane, **plane),
        bodies=LinkBodies(**bodies),
        adc=_parse_adc(path, adc_table),
    )


def _parse_adc(path: Path, table: dict[str, Any]) -> ADC:
    if not table:
        return ADC()
    try:
        return adc_from_table(table)
    except SailError as exc:
        raise RobotFileError(f"{path}: [adc] {exc}") from None


def _parse_links(path: Path, data: dict[str, Any]) -> Arm:
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
