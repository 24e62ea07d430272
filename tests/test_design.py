"""sail design: each map against its closed form, the modal solver against Euler-Bernoulli and dense eigh, the CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.linalg
from click.testing import CliRunner

from sailforce.cli import cli
from sailforce.design.maps import compensation_need, overload, resolution
from sailforce.design.study import DesignError, design_grid, run_design
from sailforce.fem.frame import assemble, assemble_basis, make_frame
from sailforce.fem.model import build_model
from sailforce.fem.modes import arm_mass_basis, frame_modes, local_mass
from sailforce.fem.response import simulate
from sailforce.io.robotkeys import with_keys
from sailforce.kinematics import jacobian
from sailforce.robot import Robot

#: Closed forms hold to rounding.
CLOSED_FORM_RTOL = 1e-9
#: The issue's bound on the cantilever's first frequency against Euler-Bernoulli.
CANTILEVER_RTOL = 5e-3
#: Cholesky reduction against scipy's generalised eigh.
EIGH_RTOL = 1e-9
#: The first root of 1 + cos(bL) cosh(bL) = 0 (Euler-Bernoulli cantilever).
BETA1_L = 1.8751040687119611


def _poses(n: int = 40, seed: int = 2):
    rng = np.random.default_rng(seed)
    delta = rng.uniform(np.radians(15), np.radians(165), n)
    theta2 = rng.uniform(-1.0, 1.0, n)
    return delta + theta2, theta2


def test_pin_resolution_equals_its_closed_form():
    """Pin joints: S = g diag(1/l1, 1/l2) J^T, so C_F = (sigma/g)^2 J^-T diag(l1^2, l2^2) J^-1."""
    robot = Robot()
    theta1, theta2 = _poses()
    response = simulate(robot, theta1, theta2)
    sigma = robot.loadcell.noise_mV_V
    got = resolution(response.signal("bridge"), sigma)
    g = robot.loadcell.rated_output_mV_V / robot.loadcell.capacity_N
    jinv = np.linalg.inv(jacobian(robot.arm, theta1, theta2))
    lengths2 = np.diag([robot.arm.l1**2, robot.arm.l2**2])
    expected = (sigma / g) ** 2 * np.swapaxes(jinv, -1, -2) @ lengths2 @ jinv
    np.testing.assert_allclose(got.covariance, expected, rtol=CLOSED_FORM_RTOL, atol=1e-12 * np.abs(expected).max())
    # its area goes as 1/|sin delta|; its worst axis does not
    area = got.axes[:, 0] * got.axes[:, 1] * np.abs(np.sin(theta1 - theta2))
    np.testing.assert_allclose(area, area[0], rtol=CLOSED_FORM_RTOL)
    worst = got.worst * np.abs(np.sin(theta1 - theta2))
    assert np.ptp(worst) / worst.mean() > 0.05


def test_pin_overload_follows_from_statics_by_hand():
    """Cells limit (links made strong): cell i saturates when |T_i| / l_i = capacity, T = J^T F."""
    robot = with_keys(Robot(), {"materials.links.yield_strength": 1e15})
    theta1, theta2 = _poses(12)
    got = overload(simulate(robot, theta1, theta2))
    u = np.stack([np.cos(got.directions), np.sin(got.directions)])  # (2, D)
    jt = np.swapaxes(jacobian(robot.arm, theta1, theta2), -1, -2) @ u  # (n, 2, D): T_i per unit force along phi
    lengths = np.array([robot.arm.l1, robot.arm.l2])[None, :, None]
    expected = (robot.loadcell.capacity_N * lengths / np.abs(jt)).min(axis=1)
    np.testing.assert_allclose(got.per_direction, expected, rtol=CLOSED_FORM_RTOL)
    assert set(got.limiting_names()) <= {"load cell 1", "load cell 2"}


def test_links_limit_when_their_yield_is_low():
    robot = with_keys(Robot(), {"materials.links.yield_strength": 1e6})
    got = overload(simulate(robot, *_poses(5)), safety_factor=2.0)
    assert not any(name.startswith("load cell") for name in got.limiting_names())
    halved = overload(simulate(robot, *_poses(5)), safety_factor=4.0)
    np.testing.assert_allclose(halved.worst, got.worst / 2.0, rtol=CLOSED_FORM_RTOL)


def _allowed_along(response, robot, phi, safety_factor=2.0):
    """The largest hand force along ``phi`` (one per pose) by member_stresses and the bridge, independently of maps."""
    from sailforce.fem.model import MEMBERS
    from sailforce.fem.response import member_stresses

    c, s = np.cos(phi), np.sin(phi)
    stresses = member_stresses(response, c, s)
    links = np.array([kind != "cell" for *_, kind in MEMBERS])
    link_limit = (stresses.yield_strength / (safety_factor * stresses.von_mises.max(axis=-1)))[..., links].min(axis=-1)
    bridge = response.signal("bridge")
    cell_limit = (robot.loadcell.rated_output_mV_V / np.abs(bridge[..., 0] * c[..., None] + bridge[..., 1] * s[..., None]))
    return np.minimum(link_limit, cell_limit.min(axis=-1))


@pytest.mark.parametrize("keys", [{}, {"joints.model": "bonded"}, {"materials.links.yield_strength": 3e6},
                                  {"joints.model": "bonded", "materials.links.yield_strength": 2e6}])  # fmt: skip
def test_overload_worst_direction_is_exact(keys):
    """The closed-form worst lies below every sampled direction, within cos(2.5 deg) of the 5-deg samples, and is
    what member_stresses gives along the worst direction it names."""
    robot = with_keys(Robot(), keys)
    theta1, theta2 = _poses(40)
    response = simulate(robot, theta1, theta2)
    got = overload(response)
    sampled = got.per_direction.min(axis=-1)
    assert np.all(got.worst <= sampled * (1 + 1e-12))
    assert np.all(sampled <= got.worst / math.cos(math.radians(2.5)) * (1 + 1e-12))
    np.testing.assert_allclose(_allowed_along(response, robot, got.worst_direction), got.worst, rtol=1e-9)
    k = 11
    np.testing.assert_allclose(_allowed_along(response, robot, np.full(theta1.shape, got.directions[k])),
                               got.per_direction[:, k], rtol=1e-12)  # fmt: skip


def test_pin_joints_need_no_compensation_and_bonded_joints_do():
    theta1, theta2 = _poses(10)
    pin = compensation_need(simulate(Robot(), theta1, theta2))
    assert np.abs(pin.phase_deg).max() < 1e-8 and np.abs(pin.amplitude - 1).max() < 1e-9
    bonded = compensation_need(simulate(with_keys(Robot(), {"joints.model": "bonded"}), theta1, theta2))
    assert bonded.worst_phase_deg.max() > 5.0


def _cantilever(elements: int, length: float = 1.0, EI: float = 2.0, EA: float = 1e4, rho_A: float = 3.0):
    """A horizontal cantilever of ``elements`` Euler-Bernoulli members, clamped at node 0."""
    n_nodes = elements + 1
    dofs = [[3 * e, 3 * e + 1, 3 * e + 2, 3 * e + 3, 3 * e + 4, 3 * e + 5] for e in range(elements)]
    from sailforce.fem.elements import local_stiffness

    L = length / elements
    k = np.broadcast_to(local_stiffness(EA, EI, L, 0.0), (elements, 6, 6))
    fixed = np.zeros(3 * n_nodes, dtype=bool)
    fixed[:3] = True
    frame = make_frame(3 * n_nodes, 1, dofs, np.zeros(elements, int), k, fixed)
    from sailforce.fem.frame import matrix_basis

    mass = matrix_basis(frame, np.broadcast_to(local_mass(rho_A, L), (elements, 6, 6)))
    exact = BETA1_L**2 * math.sqrt(EI / (rho_A * length**4)) / (2 * math.pi)
    return frame, mass, exact


@pytest.mark.parametrize("elements", [1, 4])
def test_cantilever_first_frequency_matches_euler_bernoulli(elements):
    frame, mass, exact = _cantilever(elements)
    for angle in (0.0, 0.7):  # the frequency does not depend on the direction the beam points
        modes = frame_modes(frame, mass, np.array([[angle]]), count=1)
        assert modes.frequencies_Hz[0, 0] == pytest.approx(exact, rel=CANTILEVER_RTOL)


def test_modal_solver_agrees_with_dense_eigh_per_pose():
    robot = with_keys(Robot(), {"joints.model": "spring", "handle.mass": 0.4})
    model = build_model(robot)
    theta1, theta2 = _poses(6)
    angles = np.stack([theta1, theta2], axis=-1)
    basis = arm_mass_basis(model)
    modes = frame_modes(model.frame, basis, angles, count=4)
    K, M = assemble(model.frame, angles), assemble_basis(basis, angles)
    for k in range(len(angles)):
        w = scipy.linalg.eigh(K[k], M[k], eigvals_only=True)[:4]
        np.testing.assert_allclose((2 * math.pi * modes.frequencies_Hz[k]) ** 2, w, rtol=EIGH_RTOL)
        phi = modes.shapes[k][~model.frame.fixed]
        np.testing.assert_allclose(phi.T @ M[k] @ phi, np.eye(4), atol=1e-9)


def test_mass_matrix_carries_the_arm_and_handle_mass():
    """A rigid translation's kinetic mass is every member's rho A L plus the handle's, wherever it sits."""
    from dataclasses import replace

    from sailforce.fem.model import MEMBERS

    robot = with_keys(Robot(), {"handle.mass": 0.7, "handle.position": 0.3})
    model = build_model(robot)
    loose = replace(model, frame=replace(model.frame, fixed=np.zeros(model.frame.n_dofs, dtype=bool)))
    M = assemble_basis(arm_mass_basis(loose), np.array([[0.9, 0.1]]))[0]
    for axis in ("u", "v"):
        t = np.zeros(model.frame.n_dofs)
        t[[index for name, index in model.dof.items() if name.endswith(f".{axis}")]] = 1.0
        link = robot.link_material.rho * robot.link_section.area
        cell = robot.loadcell.material.rho * robot.loadcell.block.area
        per = np.array([cell if kind == "cell" else link for *_, kind in MEMBERS])
        assert t @ M @ t == pytest.approx(float(per @ model.lengths) + 0.7, rel=CLOSED_FORM_RTOL)


def test_per_link_sections_and_materials_reach_stiffness_mass_and_stress():
    """A heavier, deeper l3 and an aluminium l4: the mass is the hand sum, pin torques stay J^T F, l3 stresses drop."""
    from dataclasses import replace

    from sailforce.fem.model import MEMBER_LINK, MEMBERS
    from sailforce.fem.response import member_stresses

    base = Robot()
    robot = with_keys(base, {"sections.l3.depth": 0.04, "sections.l3.thickness": 0.012, "materials.l4.rho": 2700.0,
                             "materials.l4.E": 7.0e10})  # fmt: skip
    assert robot.section("l1") == base.link_section and robot.material("l3") == base.link_material
    model = build_model(robot)
    loose = replace(model, frame=replace(model.frame, fixed=np.zeros(model.frame.n_dofs, dtype=bool)))
    M = assemble_basis(arm_mass_basis(loose), np.array([[1.2, -0.3]]))[0]
    t = np.zeros(model.frame.n_dofs)
    t[[index for name, index in model.dof.items() if name.endswith(".u")]] = 1.0
    cell = robot.loadcell.material.rho * robot.loadcell.block.area
    by_link = {"l1": 7800 * 2.5e-4, "l2": 7800 * 2.5e-4, "l3": 7800 * 0.04 * 0.012, "l4": 2700 * 2.5e-4}
    per = np.array([cell if kind == "cell" else by_link[link] for (*_, kind), link in zip(MEMBERS, MEMBER_LINK)])
    assert t @ M @ t == pytest.approx(float(per @ model.lengths), rel=CLOSED_FORM_RTOL)
    # pin joints: the torques are statics alone, whatever the sections
    theta1, theta2 = np.radians([100.0, 70.0]), np.radians([10.0, -20.0])
    pin = simulate(robot.with_joints("pin"), theta1, theta2)
    np.testing.assert_allclose(pin.torques, simulate(base.with_joints("pin"), theta1, theta2).torques, rtol=1e-9)
    # statically determinate: the same internal forces; l3's stress from its own section, |N|/(t d) + |M|/(t d^2/6)
    heavy, plain = (member_stresses(simulate(r.with_joints("pin"), theta1, theta2), 1.0, 0.0) for r in (robot, base))
    l3 = [i for i, link in enumerate(MEMBER_LINK) if link == "l3"]
    np.testing.assert_allclose(heavy.moment, plain.moment, rtol=1e-9, atol=1e-12)
    by_hand = np.abs(heavy.axial[:, l3]) / (0.012 * 0.04) + np.abs(heavy.moment[:, l3]) / (0.012 * 0.04**2 / 6)
    np.testing.assert_allclose(heavy.normal_stress[:, l3], by_hand, rtol=1e-12)


def test_design_grid_refuses_impossible_limits():
    with pytest.raises(DesignError, match="no pose"):
        design_grid(Robot(), 10, (0, 10), (50, 60), (15, 165))
    with pytest.raises(DesignError, match="low < high"):
        design_grid(Robot(), 10, (90, 10))


def test_design_poses_are_reachable_and_within_limits():
    grid = design_grid(Robot(), 20)
    delta = np.degrees(grid.theta1 - grid.theta2)
    assert grid.theta1.size == grid.mask.sum() > 50
    assert delta.min() >= 15 - 1e-6 and delta.max() <= 165 + 1e-6


def test_sail_design_writes_json_figures_report(tmp_path):
    result = CliRunner().invoke(cli, ["design", "-o", str(tmp_path), "--grid", "15", "--dpi", "50"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    data = json.loads((tmp_path / "design.json").read_text())
    poses = data["poses"]
    names = ("theta1_deg", "theta2_deg", "resolution_N", "overload_N", "first_frequency_Hz")
    lengths = {len(poses[name]) for name in names}
    assert len(lengths) == 1 and lengths.pop() > 10
    design = run_design(Robot(), design_grid(Robot(), 15))
    np.testing.assert_allclose(poses["resolution_N"], design.resolution.worst, rtol=1e-12)
    assert data["summary"]["overload_N"]["worst"] == pytest.approx(min(poses["overload_N"]))
    for name in ("resolution.png", "overload.png", "compensation.png", "modes.png", "report.md", "report.html"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert "data:image/png;base64," in (tmp_path / "report.html").read_text()


def test_sail_design_bad_range_is_a_clear_error(tmp_path):
    result = CliRunner().invoke(cli, ["design", "-o", str(tmp_path), "--theta1-deg", "abc"])
    assert result.exit_code != 0 and "LOW:HIGH" in result.output and "Traceback" not in result.output
