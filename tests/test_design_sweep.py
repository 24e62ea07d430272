"""sail design --sweep and --capacity-catalogue: the table, the refusals, the Pareto set, the ranking, Dask."""

from __future__ import annotations

import itertools
import os
import signal
import threading
import time
from dataclasses import replace

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from sailforce.cli import cli
from sailforce.design.study import DesignError
from sailforce.design.sweep import (
    GridSpec,
    Requirements,
    Task,
    evaluate,
    evaluate_safely,
    pareto_mask,
    parse_sweep,
    read_catalogue,
    run_sweep,
    variants,
)
from sailforce.distributed import ClusterError, run_tasks
from sailforce.fem.frame import compiled_solves
from sailforce.fem.model import build_model
from sailforce.fem.modes import arm_frequencies, arm_modes
from sailforce.io.robotkeys import with_keys
from sailforce.robot import Robot
from tests.dask_cluster import local_cluster

#: A coarse grid keeps each variant to a few tens of milliseconds.
SMALL = GridSpec(n=12)


def _brute_force_pareto(costs: np.ndarray) -> np.ndarray:
    keep = []
    for i, a in enumerate(costs):
        keep.append(not any(np.all(b <= a) and np.any(b < a) for j, b in enumerate(costs) if j != i))
    return np.array(keep)


def test_pareto_mask_is_the_non_dominated_set_by_brute_force():
    rng = np.random.default_rng(4)
    for n, k in ((1, 3), (40, 2), (200, 3)):
        costs = rng.integers(0, 6, size=(n, k)).astype(float)  # small integers: many ties and duplicates
        np.testing.assert_array_equal(pareto_mask(costs), _brute_force_pareto(costs))


def test_sweep_table_has_one_row_per_variant_and_a_non_dominated_pareto_set():
    robot = Robot()
    axes = [parse_sweep("loadcells.position=0.3:0.7:0.2", robot), parse_sweep("loadcells.capacity_kg=10,50", robot),
            parse_sweep("joints.model=pin,bonded", robot)]  # fmt: skip
    result = run_sweep(robot, axes, grid=SMALL, requirements=Requirements(required_force_N=60.0))
    c = result.columns
    assert len(result) == 3 * 2 * 2 and all(len(v) == len(result) for v in c.values())
    combos = set(zip(c["loadcells.position"].tolist(), c["loadcells.capacity_kg"].tolist(), c["joints.model"].tolist()))
    assert combos == set(itertools.product([0.3, 0.5, 0.7], [10.0, 50.0], ["pin", "bonded"]))
    assert np.all(c["status"] == "ok")
    objectives = np.stack([c["resolution_N"], -c["overload_N"], -c["first_frequency_Hz"]], axis=-1)
    np.testing.assert_array_equal(result.pareto, _brute_force_pareto(np.array([[float(f"{v:.9g}") for v in row]
                                                                                for row in objectives])))  # fmt: skip
    # ranked: exactly the variants that carry 60 N, best resolution first
    meets = c["overload_N"] >= 60.0
    assert set(np.flatnonzero(c["rank"] > 0)) == set(np.flatnonzero(meets)) and 0 < meets.sum() < len(result)
    ranked = result.ranked()
    assert np.all(np.diff(np.round(c["resolution_N"][ranked], 4)) >= 0)
    # one row agrees with evaluating its variant alone
    i = int(ranked[0])
    alone = evaluate(Task(with_keys(robot, {"loadcells.position": c["loadcells.position"][i],
                                            "loadcells.capacity_kg": c["loadcells.capacity_kg"][i],
                                            "joints.model": str(c["joints.model"][i])}), SMALL))  # fmt: skip
    assert alone["resolution_N"] == pytest.approx(c["resolution_N"][i], rel=1e-12)


def test_pin_sweep_rows_follow_the_closed_forms():
    """Pin joints: each cell reads T_i / l_i, so the worst overload is capacity x l1 / l3 (cell 1 at the
    handle's far reach), and resolution scales with capacity / rated output; the cell's place changes neither."""
    robot = Robot()
    axes = [parse_sweep("loadcells.capacity_kg=10,40", robot), parse_sweep("loadcells.position=0.3,0.7", robot)]
    c = run_sweep(robot, axes, grid=SMALL).columns
    capacity_N = c["loadcells.capacity_kg"] * 9.80665
    np.testing.assert_allclose(c["overload_N"], capacity_N * robot.arm.l1 / robot.arm.l3, rtol=1e-9)
    ratio = c["resolution_N"] / c["loadcells.capacity_kg"]
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)


def test_bad_sweep_keys_and_values_are_refused_naming_the_key():
    robot = Robot()
    for text, match in (("loadcells.positon=0.2", "loadcells.positon"), ("loadcells.position=a,b", "loadcells.position"),
                        ("loadcells.position=0.2:0.8:-0.1", "loadcells.position"), ("position", "KEY=")):  # fmt: skip
        with pytest.raises(DesignError, match=match):
            parse_sweep(text, robot)
    with pytest.raises(DesignError, match=r"loadcells.position = 0.95"):
        variants(robot, [parse_sweep("loadcells.position=0.5,0.95", robot)])
    with pytest.raises(DesignError, match="joints.model = rubber"):
        variants(robot, [parse_sweep("joints.model=pin,rubber", robot)])
    result = CliRunner().invoke(cli, ["design", "-o", "unused", "--sweep", "links.l9=0.2"])
    assert result.exit_code != 0 and "links.l9" in result.output and "Traceback" not in result.output


def test_a_variant_that_cannot_be_mapped_is_a_row_with_its_reason():
    """An arm whose joint limits leave no pose is reported in its row, not dropped."""
    row = evaluate_safely(Task(Robot(), GridSpec(n=10, theta1_deg=(0.0, 10.0), theta2_deg=(50.0, 60.0))))
    assert row["status"].startswith("no pose") and "resolution_N" not in row


def test_catalogue_ranks_cells_by_resolution_then_price(tmp_path):
    path = tmp_path / "cells.csv"
    path.write_text(
        "name,capacity_kg,rated_output_mV_V,rated_deflection_m,price\n"
        "tiny,5,2,0.0003,20\n"  # carries 5 kg x 0.2/0.45 = 21.8 N: below 45 N, not ranked
        "mid,20,2,0.0004,50\n"
        "mid-cheap,20,2,0.0004,35\n"  # same cell, cheaper: ranks first
        "big,50,3,0.0005,40\n"  # higher output, but 2.5x the capacity: noisier per newton
    )
    axis = read_catalogue(path)
    result = run_sweep(Robot(), [axis], grid=SMALL)
    c = result.columns
    order = [str(c["cell"][i]) for i in result.ranked()]
    assert order == ["mid-cheap", "mid", "big"]
    assert c["rank"][list(c["cell"]).index("tiny")] == 0
    assert c["price"].tolist() == [20.0, 50.0, 35.0, 40.0]
    # resolution ~ capacity / rated output (pin joints): big / mid = (50/3) / (20/2)
    mid, big = (c["resolution_N"][list(c["cell"]).index(n)] for n in ("mid", "big"))
    assert big / mid == pytest.approx((50 / 3) / (20 / 2), rel=1e-9)


def test_catalogue_errors_name_the_line_and_column(tmp_path):
    path = tmp_path / "cells.csv"
    path.write_text("name,capacity_kg,rated_output_mV_V,price\nA,5,2,20\n")
    with pytest.raises(DesignError, match="rated_deflection_m"):
        read_catalogue(path)
    path.write_text("name,capacity_kg,rated_output_mV_V,rated_deflection_m,price\nA,5,two,0.0003,20\n")
    with pytest.raises(DesignError, match=r"cells.csv:2: rated_output_mV_V = 'two'"):
        read_catalogue(path)
    with pytest.raises(DesignError, match="no such catalogue"):
        read_catalogue(tmp_path / "none.csv")


def test_subspace_frequencies_agree_with_the_dense_solver():
    theta1, theta2 = np.radians([40.0, 95.0, 150.0, 120.0]), np.radians([-30.0, 10.0, 60.0, 100.0])
    for keys in ({}, {"joints.model": "bonded"}, {"joints.model": "spring", "joints.stiffness": 5.0, "handle.mass": 2.0}):
        model = build_model(with_keys(Robot(), keys))
        dense = arm_modes(model, theta1, theta2, 2).frequencies_Hz
        np.testing.assert_allclose(arm_frequencies(model, theta1, theta2, 2), dense, rtol=1e-8)
        with compiled_solves():  # the compiled subspace iteration (profile Cholesky, Jacobi on the projection)
            for count in (1, 2):
                np.testing.assert_allclose(arm_frequencies(model, theta1, theta2, count), dense[:, :count], rtol=1e-8)


def test_a_large_sweep_solves_compiled_and_a_small_one_does_not(monkeypatch):
    """A sweep whose poses pay for loading numba (COMPILED_MIN_POSES) asks its tasks for the compiled solve; the
    answers are the numpy path's to the eigensolver's rounding."""
    import sailforce.distributed as distributed

    seen = []

    def record(fn, tasks, **options):  # the tasks as handed out, each answered as one that failed
        seen.extend(tasks)
        return [distributed.Outcome(error="not run") for _ in tasks]

    monkeypatch.setattr(distributed, "run_tasks", record)
    axis = parse_sweep("loadcells.position=0.4,0.6", Robot())
    for n, compiled in ((10, False), (200, True)):
        seen.clear()
        run_sweep(Robot(), [axis], grid=GridSpec(n=n))
        assert len(seen) == 2 and all(task.compiled is compiled for task in seen), (n, [t.compiled for t in seen])
    task = Task(Robot().with_joints("bonded"), GridSpec(n=12))  # bonded: a phase need well above rounding
    plain, fast = evaluate(task), evaluate(replace(task, compiled=True))
    for key in ("resolution_N", "overload_N", "first_frequency_Hz", "phase_need_deg"):
        assert fast[key] == pytest.approx(plain[key], rel=1e-8), key


def test_cli_sweep_writes_the_table_figure_and_report(tmp_path):
    out = tmp_path / "d"
    result = CliRunner().invoke(cli, ["design", "-o", str(out), "--grid", "12", "--dpi", "50", "-q",
                                      "--sweep", "loadcells.position=0.4,0.6", "--sweep", "loadcells.capacity_kg=20,50"])  # fmt: skip
    assert result.exit_code == 0, result.output
    table = pq.read_table(out / "sweep.parquet").to_pydict()
    assert len(table["variant"]) == 4 and set(table["loadcells.position"]) == {0.4, 0.6}
    assert (out / "sweep.csv").read_text().count("\n") == 5 and (out / "pareto.png").stat().st_size > 0
    assert "## Sweep" in (out / "report.md").read_text()


def test_local_cluster_gives_the_in_process_rows():
    robot = Robot()
    axes = [parse_sweep("loadcells.position=0.3,0.5,0.7", robot)]
    here = run_sweep(robot, axes, grid=SMALL)
    there = run_sweep(robot, axes, grid=SMALL, workers=2)
    for name in ("resolution_N", "overload_N", "first_frequency_Hz"):
        np.testing.assert_array_equal(there.columns[name], here.columns[name])


def test_cluster_options_are_checked():
    with pytest.raises(ClusterError, match="not both"):
        run_tasks(abs, [1], workers=2, scheduler="tcp://127.0.0.1:1")


def _slow_row(task: Task) -> dict:
    time.sleep(0.4)  # long enough that a worker is killed with tasks in hand
    return {**evaluate(task), "pid": os.getpid()}


def test_a_killed_worker_loses_no_variant(tmp_path):
    """A real `dask scheduler` and two `dask worker`s on 127.0.0.1; one worker is killed mid-sweep, and every
    variant still comes back exactly once, computed."""
    with local_cluster(tmp_path) as (address, workers):  # the workers import tests.test_design_sweep for _slow_row
        tasks = [Task(with_keys(Robot(), {"loadcells.position": p}), SMALL) for p in np.linspace(0.3, 0.7, 12)]
        killed = threading.Event()

        def advance(amount: float) -> None:
            if not killed.is_set():  # the first result is in: kill a worker with work still queued
                os.killpg(workers[0].pid, signal.SIGKILL)
                killed.set()

        outcomes = run_tasks(_slow_row, tasks, scheduler=address, advance=advance)
        assert killed.is_set() and workers[0].wait(timeout=10) is not None
        assert len(outcomes) == len(tasks) and all(o.ok for o in outcomes), [o.error for o in outcomes]
        for task, outcome in zip(tasks, outcomes):
            assert outcome.value["resolution_N"] == pytest.approx(evaluate(task)["resolution_N"], rel=1e-12)
        assert workers[1].pid in {o.value["pid"] for o in outcomes}  # the survivor took over
