"""`make bench`'s figures file: each benchmark's latest run, with its date, machine and commit, machine-readable."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _runner(monkeypatch):
    for name in ("bench_fake", "bench_other"):  # each test's own modules, not an earlier test's
        monkeypatch.delitem(sys.modules, name, raising=False)
    spec = importlib.util.spec_from_file_location("bench_runner", ROOT / "bench" / "run.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_each_benchmark_s_figures_land_in_the_file_and_a_subset_keeps_the_others(tmp_path, monkeypatch, capsys):
    for name, figures in (("fake", [("speed", "   12.5 calls/s"), ("ratio", " 3.4x")]), ("other", [("size", "1,608 bytes")])):
        (tmp_path / f"bench_{name}.py").write_text(f'"""The {name} benchmark."""\n\ndef run():\n    return {figures!r}\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    runner = _runner(monkeypatch)
    out = tmp_path / "figures.json"
    assert runner.main(["fake", "--json", str(out)]) == 0
    assert runner.main(["other", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["format"] == "sailforce-bench-figures" and set(data["benchmarks"]) == {"fake", "other"}
    fake = data["benchmarks"]["fake"]
    assert fake["description"] == "The fake benchmark."
    assert fake["figures"] == [{"label": "speed", "figure": "12.5 calls/s"}, {"label": "ratio", "figure": "3.4x"}]
    assert fake["machine"]["cores"] >= 1 and fake["machine"]["python"] == ".".join(map(str, sys.version_info[:3]))
    assert fake["date"].endswith("+00:00") and fake["seconds"] >= 0
    assert "12.5 calls/s" in capsys.readouterr().out  # printed as before
    # a rerun replaces that benchmark's entry only
    (tmp_path / "bench_fake.py").write_text('"""The fake benchmark."""\n\ndef run():\n    return [("speed", "13.0 calls/s")]\n')
    sys.modules.pop("bench_fake", None)
    assert runner.main(["fake", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["benchmarks"]["fake"]["figures"] == [{"label": "speed", "figure": "13.0 calls/s"}]
    assert data["benchmarks"]["other"]["figures"] == [{"label": "size", "figure": "1,608 bytes"}]


def test_a_damaged_figures_file_is_started_afresh(tmp_path, monkeypatch):
    (tmp_path / "bench_fake.py").write_text('"""The fake benchmark."""\n\ndef run():\n    return [("speed", "1")]\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "figures.json"
    out.write_text("{ not json")
    assert _runner(monkeypatch).main(["fake", "--json", str(out)]) == 0
    assert set(json.loads(out.read_text())["benchmarks"]) == {"fake"}
