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
    assert {"sailforce.kernel", "sailforce.calibration.estimator", "sailforce.io.robotfile"} <= set(graph)
    assert "sailforce.kernel" in graph["sailforce.calibration.estimator"]  # the graph sees relative imports
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
