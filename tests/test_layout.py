"""The package's shape: every import points downward (no module imports, even lazily, one that imports it back)."""

from __future__ import annotations

import ast
from pathlib import Path

import sailforce

PACKAGE = Path(sailforce.__file__).parent


def _module_name(path: Path) -> str:
    parts = ("sailforce",) + path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, name: str, known: set[str]) -> set[str]:
    """The sailforce modules ``path`` imports, at its top or inside functions."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            # `from package import module` imports the module; `from module import name`, the module
            candidates = [f"{target}.{a.name}" if f"{target}.{a.name}" in known else target for a in node.names]
        elif isinstance(node, ast.Import):
            candidates = [alias.name for alias in node.names]
        else:
            continue
        found |= {c for c in candidates if c in known and c != name}
    return found


def _graph() -> dict[str, set[str]]:
    paths = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    return {name: _imports(path, name, set(paths)) for name, path in paths.items()}


def test_imports_point_downward():
    graph = _graph()
    assert {"sailforce.kernel", "sailforce.estimate.estimator", "sailforce.io.robotfile"} <= set(graph)
    assert "sailforce.kernel" in graph["sailforce.estimate.estimator"]  # the graph sees relative imports
    order, state = [], {}

    def visit(name: str, path: tuple[str, ...]) -> None:  # depth-first; a grey node met again is a cycle
        if state.get(name) == "done":
            return
        assert state.get(name) != "open", "import cycle: " + " -> ".join(path[path.index(name):] + (name,))
        state[name] = "open"
        for target in sorted(graph[name]):
            visit(target, path + (name,))
        state[name] = "done"
        order.append(name)

    for name in sorted(graph):
        visit(name, ())
    assert len(order) == len(graph)


#: The house, from the ground up: a package or module imports only from the floors below its own (and,
#: inside one package, from its own modules).  Every module of sailforce must be on exactly one floor.
LAYERS: tuple[tuple[str, frozenset[str]], ...] = tuple((floor, frozenset(names.split())) for floor, names in (
    ("errors for people", "errors"),
    ("the ground: boundary checks, blocks, signals, extras, status codes, version, moved paths",
     "_validate _blocks _signals _extras _moved _lazy _version status"),
    ("kinematics (Eqs. 1, 4) and materials", "kinematics materials"),
    ("the force kernel: J^T and the 2x2 solve (Eq. 8)", "kernel"),
    ("statics (Eqs. 3, 6-8)", "statics"),
    ("the arm, the load cell and its ADC, their drift", "arm loadcell adc drift"),
    ("the robot", "robot"),
    ("files, tables, the robot file; the cluster", "io distributed"),
    ("the frame model; the sensing maps", "fem sensing"),
    ("simulated recordings and sweeps", "synthetic sweep"),
    ("motion", "motion"),
    ("run-time estimation", "estimate"),
    ("the calibration: data and file", "calibration"),
    ("fitting", "fit"),
    ("the paper, design, calibration plans, the solid, the stream pipeline, C export, rig checks, reference sensors",
     "paper design plan solid stream export_c rig reference"),
    ("workflows", "workflows"),
    ("the package's public names", "sailforce"),
    ("live", "live"),
    ("report", "report"),
    ("the command line", "cli"),
    ("python -m sailforce", "__main__"),
))


def _floor_of(name: str) -> tuple[int, str]:
    """The floor of a module, and the unit (top-level package or module) that owns it."""
    unit = name.split(".")[1] if name.count(".") else "sailforce"
    floors = [i for i, (_, units) in enumerate(LAYERS) if unit in units]
    assert len(floors) == 1, f"{name}: its unit {unit!r} is on {len(floors)} floors of LAYERS; put it on one"
    return floors[0], unit


def _stand_ins() -> set[str]:
    """The old paths kept for one release (:mod:`sailforce._moved`)."""
    graph = _graph()
    return {name for name in graph if "_moved" in {t.rpartition(".")[2] for t in graph[name]} and name != "sailforce._moved"}


def test_every_module_is_on_one_floor():
    stand_ins = _stand_ins()
    for name in _graph():
        if name not in stand_ins:
            _floor_of(name)


def test_imports_go_down_the_floors():
    """Lazy imports count; a stand-in for an old path is exempt, and nothing may import one."""
    graph, stand_ins = _graph(), _stand_ins()
    assert {"sailforce.calibration.compensation", "sailforce.study"} <= stand_ins  # the detector sees them
    wrong = []
    for name, targets in graph.items():
        if name in stand_ins:
            assert targets == {"sailforce._moved"}, f"{name} is a stand-in: it imports only sailforce._moved"
            continue
        floor, unit = _floor_of(name)
        for target in targets:
            assert target not in stand_ins, f"{name} imports {target}, an old path kept only for users: import the new one"
            target_floor, target_unit = _floor_of(target)
            if target_unit != unit and target_floor >= floor:
                wrong.append(f"{name} (floor {floor}, {LAYERS[floor][0]}) imports {target} (floor {target_floor})")
    assert not wrong, "imports that do not go down:\n" + "\n".join(sorted(wrong))


def test_the_floors_are_ordered():
    """The check is not blind: an import from kinematics to the CLI would go up."""
    low, high = _floor_of("sailforce.kinematics"), _floor_of("sailforce.cli.estimate_cmd")
    assert low[0] < high[0] and low[1] != high[1]  # so that kinematics -> cli would be reported
def test_packages_import_downward():
    """Between the subpackages too: calibration builds on motion and io, never the reverse."""
    graph = _graph()
    top = {name: name.split(".")[1] if name.count(".") else "" for name in graph}
    uses: dict[str, set[str]] = {}
    for name, targets in graph.items():
        for target in targets:
            if top[target] != top[name] and top[name] and top[target]:
                uses.setdefault(top[name], set()).add(top[target])
    for low, high in (("motion", "calibration"), ("io", "calibration"), ("kernel", "statics"), ("fem", "calibration")):
        assert high not in uses.get(low, set()), f"{low} imports {high}"
