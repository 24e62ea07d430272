"""The public API: what users import, the workflows as library calls, result objects, one exception hierarchy."""

from __future__ import annotations

import ast
import importlib
import inspect
import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import sailforce
from sailforce import errors

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = Path(sailforce.__file__).parent
PACKAGES = sorted(p.parent.name for p in PACKAGE.glob("*/__init__.py"))
#: Where users read how to import sailforce: every code example of the docs, the figure scripts, the C vectors' generator.
EXAMPLE_FILES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "docs").glob("*.py")])
IMPORT = re.compile(r"^[ \t>]*from (sailforce[\w.]*) import (\([\w ,\n]+\)|[\w ,]+)$", re.M)


def _imports(path: Path) -> list[tuple[str, list[str]]]:
    found = []
    for match in IMPORT.finditer(path.read_text(encoding="utf-8")):
        names = [n.strip().split(" as ")[0] for n in match[2].strip("()").replace("\n", " ").split(",") if n.strip()]
        found.append((match[1], names))
    return found


def test_examples_import_only_public_names():
    """Docs import from ``sailforce`` or a subpackage, and only names that its ``__all__`` lists."""
    seen = 0
    for path in EXAMPLE_FILES:
        for module, names in _imports(path):
            seen += 1
            where = f"{path.relative_to(ROOT)}: from {module} import {', '.join(names)}"
            assert module == "sailforce" or (module.count(".") == 1 and module.split(".")[1] in PACKAGES), \
                f"{where}: import from sailforce or one of its packages, not a module inside one"  # fmt: skip
            public = importlib.import_module(module).__all__
            for name in names:
                assert name in public, f"{where}: {name} is not one of {module}'s public names"
    assert seen >= 12  # the pages do import sailforce: the pattern is not blind


@pytest.mark.parametrize("package", ["sailforce", *(f"sailforce.{p}" for p in PACKAGES)])
def test_every_public_name_resolves(package):
    module = importlib.import_module(package)
    public = getattr(module, "__all__", None)
    assert public, f"{package} lists no public names (__all__)"
    for name in public:
        value = getattr(module, name)
        if package != "sailforce" and not inspect.ismodule(value) and hasattr(value, "__module__") and callable(value):
            home = value.__module__
            assert home.startswith(package) or home in ("sailforce.errors", "sailforce.status", "sailforce.kinematics", "builtins"), \
                f"{package}.{name} is {home}'s, not the package's"  # fmt: skip
        assert name in dir(module)


def test_lazy_names_point_down_the_house():
    """``sailforce``'s names come from the floors below it (the layer table of tests/test_layout.py)."""
    from tests.test_layout import _floor_of

    top = _floor_of("sailforce")[0]
    for name in sailforce.__all__:
        value = getattr(sailforce, name)
        home = getattr(value, "__module__", None) or "sailforce.status"
        if home.startswith("sailforce."):
            assert _floor_of(home)[0] < top, f"sailforce.{name} comes from {home}, which is not below the package"


OLD_PATHS = [
    ("sailforce.calibration.compensation", "MatrixCompensator", "sailforce.sensing"),
    ("sailforce.calibration.compensation", "estimate_force", "sailforce.estimate"),
    ("sailforce.calibration.compensation", "fit_matrix_compensator", "sailforce.fit"),
    ("sailforce.calibration.estimator", "estimate", "sailforce.estimate"),
    ("sailforce.calibration.inertial", "fit_dynamic_term", "sailforce.fit"),
    ("sailforce.calibration.inertial", "DynamicTerm", "sailforce.estimate"),
    ("sailforce.calibration.fit", "fit_calibration", "sailforce.fit"),
    ("sailforce.calibration.streaming", "stream_estimate", "sailforce.stream"),
    ("sailforce.identify", "identify_table4", "sailforce.paper"),
    ("sailforce.study", "run_study", "sailforce.paper"),
    ("sailforce.seed_model", "seed_model_study", "sailforce.paper"),
]


@pytest.mark.parametrize(("old", "name", "new"), OLD_PATHS)
def test_old_import_paths_warn_and_still_work(old, name, new):
    import sys

    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=f"{re.escape(old)} has moved to"):
        module = importlib.import_module(old)
    assert getattr(module, name) is getattr(importlib.import_module(new), name)
    with pytest.raises(AttributeError, match="has no attribute 'no_such_name'"):
        module.no_such_name  # noqa: B018


def test_python_and_cli_write_the_same_calibration(cals, tmp_path):
    """``sailforce.calibrate`` is ``sail calibrate``: the same file, less its creation time."""
    from sailforce import Calibration, Robot, calibrate
    from sailforce.cli import cli

    folder, _, _ = cals
    for model, extra, kwargs in (("matrix", (), {}), ("matrix", ("--dynamics", "prior"), {"dynamics": "prior"}),
                                 ("seed", ("--capacity", "1000,2000"), {"capacity": (1000.0, 2000.0)})):  # fmt: skip
        result = CliRunner().invoke(cli, ["calibrate", str(folder / "static.csv"), "--model", model, "-q",
                                          "-o", str(tmp_path / "cli.json"), *extra])  # fmt: skip
        assert result.exit_code == 0, result.output
        calibrate(folder / "static.csv", robot=Robot(), model=model, **kwargs).save(tmp_path / "python.json")
        cli_file, python_file = (json.loads((tmp_path / n).read_text()) for n in ("cli.json", "python.json"))
        for data in (cli_file, python_file):
            data.pop("created"), data.pop("checksum")
        assert python_file == cli_file
        assert len(python_file["data_sha256"]) == 64 and python_file["metrics"]["model_selection"] == model
    loaded = Calibration.load(tmp_path / "python.json")
    assert loaded.capacity == (1000.0, 2000.0)


def test_calibrate_takes_columns_in_memory(cals):
    from sailforce import Robot, calibrate, read_all

    folder, static, _ = cals
    columns = ("theta1_deg", "theta2_deg", "load1", "load2", "fx_N", "fy_N")
    values, malformed, _ = read_all(folder / "static.csv", columns)
    assert not malformed.any()
    cal = calibrate(values, robot=Robot(), model="matrix")
    assert cal.offsets == static.offsets and cal.data_sha256 == ""  # no file: no file's checksum
    with pytest.raises(errors.TableError, match="missing column"):
        calibrate({k: v for k, v in values.items() if k != "fx_N"}, robot=Robot(), model="matrix")
    values["load1"] = values["load1"].copy()
    values["load1"][3] = np.nan
    with pytest.raises(errors.TableError, match="load1 holds a value that is not a finite number"):
        calibrate(values, robot=Robot(), model="matrix")


def test_calibrate_refuses_two_dynamic_terms(cals):
    from sailforce import Robot, calibrate

    folder, _, _ = cals
    with pytest.raises(errors.InputError, match="give one or the other"):
        calibrate(folder / "static.csv", robot=Robot(), model="matrix", free_motion=folder / "static.csv", dynamics="prior")


def test_force_results_are_objects_that_unpack_as_before():
    from sailforce import Arm, ForceResult, end_effector_force, estimate_force
    from sailforce.sensing import TorqueScale

    arm = Arm()
    theta1, theta2, t1, t2 = np.array([1.0, 0.4]), np.array([0.2, 0.4]), np.array([1.0, 2.0]), np.array([3.0, 4.0])
    masked = end_effector_force(arm, theta1, theta2, t1, t2, on_singular="mask")
    assert isinstance(masked, ForceResult) and len(masked) == 3
    fx, fy, singular = masked
    assert fx is masked.fx and fy is masked.fy and singular.tolist() == [False, True]
    assert np.isnan(masked.fx[1]) and masked[0] is masked.fx
    clean = end_effector_force(arm, 1.0, 0.2, 3.0, -4.0)
    assert len(clean) == 2 and clean.singular.shape == () and not clean.singular
    fx, fy = clean  # the old two-value form
    # the same force from the sensing map whose signals are the torques (seed Eq. 7)
    again = estimate_force(TorqueScale(arm, (1.0, 1.0)), 1.0, 0.2, 3.0, -4.0)
    assert isinstance(again, ForceResult)
    np.testing.assert_allclose([again.fx, again.fy], [fx, fy], rtol=1e-13)
    with pytest.raises(errors.InputError, match="on_singular"):
        estimate_force(TorqueScale(arm, (1.0, 1.0)), 1.0, 0.2, 3.0, -4.0, on_singular="ignore")


def test_fit_calibration_returns_a_result_object(cals):
    from sailforce import Robot, fit_calibration, read_all
    from sailforce.fit import CalibrationFit

    folder, static, _ = cals
    values, _, _ = read_all(folder / "static.csv", ("theta1_deg", "theta2_deg", "load1", "load2", "fx_N", "fy_N"))
    fit = fit_calibration(Robot().arm, np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"]), values["fx_N"],
                          values["fy_N"], values["load1"], values["load2"], kind="matrix")  # fmt: skip
    assert isinstance(fit, CalibrationFit)
    model, offsets, report = fit
    assert model is fit.model and report.kind == "matrix" and tuple(offsets) == static.offsets


def test_calibration_estimate_does_not_ignore_its_dynamic_term(cals):
    """A calibration with a dynamic term refuses to estimate as if the arm were still, unless asked to."""
    _, static, dynamic = cals
    theta1, theta2 = np.radians(60.0), np.radians(10.0)
    load = static.offsets
    with pytest.raises(errors.InputError, match="dynamic term"):
        dynamic.estimate(theta1, theta2, *load)
    still = dynamic.estimate(theta1, theta2, *load, static=True)
    assert [float(v) for v in still] == [float(v) for v in static.estimate(theta1, theta2, *load)]


def _library_modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        if "cli" not in path.relative_to(PACKAGE).parts:
            yield path


def test_every_exception_class_is_in_errors_and_in_one_family():
    families = (errors.InputError, errors.ToolError, errors.MissingExtraError)
    defined = [v for v in vars(errors).values() if isinstance(v, type) and issubclass(v, Exception)]
    assert len(defined) >= 25
    for cls in defined:
        if cls in (errors.SailError, *families):
            continue
        assert issubclass(cls, errors.SailError), cls
        assert sum(issubclass(cls, f) for f in families) == 1, f"{cls.__name__} is in {sum(issubclass(cls, f) for f in families)} families"
    assert issubclass(errors.InputError, ValueError) and issubclass(errors.ToolError, RuntimeError)
    assert issubclass(errors.MissingExtraError, ImportError)
    assert issubclass(errors.SolverError, errors.ToolError) and issubclass(errors.TableError, errors.InputError)
    elsewhere = []
    for path in _library_modules():
        if path.name == "errors.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef) and any(
                isinstance(b, ast.Name) and (b.id.endswith(("Error", "Exception")) or b.id in ("Exception", "ValueError"))
                for b in node.bases
            ):
                elsewhere.append(f"{path.relative_to(PACKAGE)}: {node.name}")
    assert not elsewhere, "exception classes outside errors.py: " + ", ".join(elsewhere)


def test_the_library_raises_no_bare_value_error():
    """An input error is an :class:`~sailforce.errors.InputError`, so that a caller can tell it from a bug."""
    bare = []
    for path in _library_modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call) and isinstance(node.exc.func, ast.Name) \
                    and node.exc.func.id in ("ValueError", "SailError"):  # fmt: skip
                bare.append(f"{path.relative_to(PACKAGE)}:{node.lineno} raises {node.exc.func.id}")
    assert not bare, "; ".join(bare)


def test_no_comment_points_to_an_issue_number():
    """Comments and docstrings say why, not which tracker entry: the tracker is not in the repository."""
    pointer = re.compile(r"\(issue \d+|issue \d+\)|\bissue #?\d+\b", re.I)
    found = [f"{p.relative_to(ROOT)}:{i}" for p in [*PACKAGE.rglob("*.py"), *(ROOT / "c").rglob("*.[ch]"), *(ROOT / "tests").glob("*.py")]
             for i, line in enumerate(p.read_text().splitlines(), 1) if pointer.search(line) and p.name != "test_api.py"]  # fmt: skip
    assert not found, ", ".join(found)


def test_the_shim_warning_is_an_error_in_the_suite():
    """pyproject turns the old-path warning into an error, so that no test uses an old path by accident."""
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        import tomllib

        filters = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["filterwarnings"]
    assert "error:.*has moved to:DeprecationWarning" in filters
