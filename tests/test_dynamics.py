"""Rigid-body dynamics of the parallelogram: the cells' shears while the arm moves.

Layers: the static limit (V_i = T_i / l_i exactly); the written-out regressor
against the Newton-Euler evaluation; an independent solve of all six bodies'
contact forces as one linear system; the motor torques of that solve against
Lagrange's equations with a mass matrix built from the bodies' Jacobians;
and the base parameters against the hand derivation in docs/dynamics.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from sailforce import Arm
from sailforce.motion.dynamics import (
    PARAMETERS,
    BodyInertia,
    InertialParameters,
    ShearModel,
    base_parameters,
    cell_shears,
    gravity_coefficients,
    parameter_vector,
    shear_regressor,
)
from sailforce.statics import joint_torques

ARM = Arm(l1=0.22, l2=0.3, l3=0.47, l4=0.3)
S = 0.5  #: cell position along l1 and l2, for the inner bodies of the independent solve


def random_body(rng, length) -> BodyInertia:
    """A body with positive mass and inertia about its centre, its centre anywhere near its span."""
    m = rng.uniform(0.2, 2.0)
    r = rng.uniform(-0.1, 1.0, 2) * [length, 0.1 * length]
    i_centre = rng.uniform(0.001, 0.05)
    return BodyInertia(m, m * r[0], m * r[1], i_centre + m * r @ r)


def random_parameters(rng) -> InertialParameters:
    return InertialParameters(*(random_body(rng, L) for L in (ARM.l1 / 2, ARM.l2 / 2, ARM.l2, ARM.l3)))


def random_states(rng, n):
    theta2 = rng.uniform(-np.pi, np.pi, n)
    theta1 = theta2 + rng.uniform(0.3, np.pi - 0.3, n) * rng.choice([-1, 1], n)
    return (theta1, theta2, *rng.normal(0, 3, (4, n)))


def test_static_limit_is_torque_over_length():
    rng = np.random.default_rng(1)
    theta1, theta2, *_ = random_states(rng, 500)
    fx, fy = rng.normal(0, 20, (2, 500))
    v1, v2 = cell_shears(ARM, random_parameters(rng), theta1, theta2, fx=fx, fy=fy)
    t1, t2 = joint_torques(ARM, theta1, theta2, fx, fy)
    np.testing.assert_allclose(v1, t1 / ARM.l1, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(v2, t2 / ARM.l2, rtol=1e-13, atol=1e-12)


def test_regressor_reproduces_newton_euler():
    rng = np.random.default_rng(2)
    params = random_parameters(rng)
    gravity = (1.3, -2.1)
    states = random_states(rng, 1000)
    v1, v2 = cell_shears(ARM, params, *states, gravity=gravity)
    Y = shear_regressor(ARM, *states)
    assert Y.shape == (1000, 2, len(PARAMETERS))
    v = Y @ parameter_vector(ARM, params, gravity)
    np.testing.assert_allclose(v[:, 0], v1, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(v[:, 1], v2, rtol=1e-12, atol=1e-12)


def test_closed_form_shears_equal_the_regressor():
    """The twelve coefficients libsail stores carry every parameter: equal to ``Y @ pi`` for any pi and motion."""
    rng = np.random.default_rng(8)
    pi = rng.normal(0, 1, len(PARAMETERS))
    states = random_states(rng, 1000)
    np.testing.assert_allclose(ShearModel.from_parameters(ARM, pi).shears(*states), shear_regressor(ARM, *states) @ pi,
                               rtol=1e-12, atol=1e-12)  # fmt: skip
    base = base_parameters(ARM)  # and the base parameters alone give the same model as the full vector
    a, b = ShearModel.from_parameters(ARM, pi), ShearModel.from_parameters(ARM, base.full(base.of(pi)))
    np.testing.assert_allclose(a.coefficients, b.coefficients, rtol=1e-12, atol=1e-12)


def _bodies(params: InertialParameters, rng):
    """All six bodies as (name, angle index, inertia); the inner parts get random inertia of their own."""
    inner1, inner2 = random_body(rng, S * ARM.l1), random_body(rng, S * ARM.l2)
    return [("inner1", 0, inner1), ("outer1", 0, params.outer1), ("inner2", 1, inner2),
            ("outer2", 1, params.outer2), ("l4", 1, params.l4), ("l3", 0, params.l3)]  # fmt: skip


def _origins(q):
    """Reference point of each body as a function of q = (theta1, theta2): B, B, B, B, P1, P2."""
    u1 = np.array([np.cos(q[0]), np.sin(q[0])])
    u2 = np.array([np.cos(q[1]), np.sin(q[1])])
    return {"inner1": 0 * u1, "outer1": 0 * u1, "inner2": 0 * u1, "outer2": 0 * u1, "l4": ARM.l1 * u1, "l3": ARM.l2 * u2}


def _centre(q, name, index, body):
    c, s = np.cos(q[index]), np.sin(q[index])
    return _origins(q)[name] + np.array([c * body.hx - s * body.hy, s * body.hx + c * body.hy]) / body.m


def _centre_jacobian(q, name, index, body):
    """d G / d q (2 x 2): the body turns with q[index]; l4's origin P1 moves with theta1, l3's P2 with theta2."""
    rotated = _centre(q, name, index, body) - _origins(q)[name]
    J = np.zeros((2, 2))
    J[:, index] = [-rotated[1], rotated[0]]
    if name in ("l4", "l3"):
        k, length = (0, ARM.l1) if name == "l4" else (1, ARM.l2)
        J[:, k] += length * np.array([-np.sin(q[k]), np.cos(q[k])])
    return J


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def solve_all_contacts(bodies, q, qd, qdd, gravity, force):
    """Every contact force of the six bodies from one 18 x 18 linear system (no closed form used).

    Unknowns: motor 1 force and torque on inner1; cut 1 force and moment on
    outer1 from inner1; pins P1 (on l4 from outer1), P3 (on l4 from l3), P2
    (on l3 from outer2); cut 2 on outer2 from inner2; motor 2 on inner2.
    Returns (tau1, tau2, C1, C2).
    """
    u = [np.array([np.cos(t), np.sin(t)]) for t in q]
    B, P1, P2 = np.zeros(2), ARM.l1 * u[0], ARM.l2 * u[1]
    P3, A = P1 + P2, P2 + ARM.l3 * u[0]
    c1, c2 = S * ARM.l1 * u[0], S * ARM.l2 * u[1]
    # unknown index: motor1 F(0,1) tau(2); cut1 C(3,4) M(5); R1(6,7); R3(8,9); R2(10,11); cut2 C(12,13) M(14);
    # motor2 F(15,16) tau(17)
    A_ = np.zeros((18, 18))
    b = np.zeros(18)
    row = {name: 3 * k for k, (name, _, _) in enumerate(bodies)}
    origin = {"inner1": B, "outer1": B, "inner2": B, "outer2": B, "l4": P1, "l3": P2}

    def apply(name, columns, point, sign=1.0, moment_column=None):
        r = row[name]
        arm_ = point - origin[name]
        A_[r, columns[0]] += sign
        A_[r + 1, columns[1]] += sign
        A_[r + 2, columns[0]] += sign * -arm_[1]  # r x F = r_x F_y - r_y F_x
        A_[r + 2, columns[1]] += sign * arm_[0]
        if moment_column is not None:
            A_[r + 2, moment_column] += sign

    apply("inner1", (0, 1), B, moment_column=2)
    apply("outer1", (3, 4), c1, moment_column=5)
    apply("inner1", (3, 4), c1, -1.0, moment_column=5)
    apply("l4", (6, 7), P1)
    apply("outer1", (6, 7), P1, -1.0)
    apply("l4", (8, 9), P3)
    apply("l3", (8, 9), P3, -1.0)
    apply("l3", (10, 11), P2)
    apply("outer2", (10, 11), P2, -1.0)
    apply("outer2", (12, 13), c2, moment_column=14)
    apply("inner2", (12, 13), c2, -1.0, moment_column=14)
    apply("inner2", (15, 16), B, moment_column=17)
    g = np.asarray(gravity)
    for name, index, body in bodies:
        r = row[name]
        # the net contact load each body needs: m (a_G - g) and, about its origin, I_G alpha + (G - O) x m (a_G - g)
        step = 1e-4  # central second difference: truncation ~1e-8 relative, rounding ~1e-9

        def centre_at(t, name=name, index=index, body=body):
            qq = q + qd * t + 0.5 * qdd * t * t
            return _centre(qq, name, index, body)
        a_g = (centre_at(step) - 2 * centre_at(0.0) + centre_at(-step)) / step**2
        net = body.m * (a_g - g)
        i_centre = body.I - (body.hx**2 + body.hy**2) / body.m
        moment = i_centre * qdd[index] + _cross(centre_at(0.0) - origin[name], net)
        b[r : r + 3] = [net[0], net[1], moment]
    # the hand's force at A acts on l3
    b[row["l3"] : row["l3"] + 2] -= force
    b[row["l3"] + 2] -= _cross(A - P2, force)
    x = np.linalg.solve(A_, b)
    return x[2], x[17], x[3:5], x[12:14]


def test_shears_match_an_independent_solve_of_every_contact_force():
    rng = np.random.default_rng(3)
    for _ in range(20):
        params = random_parameters(rng)
        bodies = _bodies(params, rng)
        theta1, theta2, w1, w2, a1, a2 = (v[0] for v in random_states(rng, 1))
        gravity, force = rng.normal(0, 3, 2), rng.normal(0, 10, 2)
        _, _, C1, C2 = solve_all_contacts(bodies, np.array([theta1, theta2]), np.array([w1, w2]), np.array([a1, a2]),
                                          gravity, force)  # fmt: skip
        v1, v2 = cell_shears(ARM, params, theta1, theta2, w1, w2, a1, a2, gravity=gravity, fx=force[0], fy=force[1])
        u1, u2 = np.array([np.cos(theta1), np.sin(theta1)]), np.array([np.cos(theta2), np.sin(theta2)])
        # the force the outer part exerts on the inner one, across the link: -u x C
        assert v1 == pytest.approx(-_cross(u1, C1), rel=1e-6, abs=1e-7)
        assert v2 == pytest.approx(-_cross(u2, C2), rel=1e-6, abs=1e-7)


def test_motor_torques_of_the_solve_obey_lagrange():
    """tau = M qdd + (Mdot qd - d/dq (qd^T M qd) / 2) + dU/dq - J^T F, M from the bodies' Jacobians (finite differences)."""
    rng = np.random.default_rng(4)
    params = random_parameters(rng)
    bodies = _bodies(params, rng)
    gravity, force = np.array([0.7, -1.9]), np.array([3.0, -4.0])

    def mass_matrix(q):
        M = np.zeros((2, 2))
        for name, index, body in bodies:
            J = _centre_jacobian(q, name, index, body)
            e = np.eye(2)[index]
            M += body.m * J.T @ J + (body.I - (body.hx**2 + body.hy**2) / body.m) * np.outer(e, e)
        return M

    def potential(q):
        return -sum(body.m * gravity @ _centre(q, name, index, body) for name, index, body in bodies)

    for _ in range(10):
        theta1, theta2, w1, w2, a1, a2 = (v[0] for v in random_states(rng, 1))
        q, qd, qdd = np.array([theta1, theta2]), np.array([w1, w2]), np.array([a1, a2])
        h = 1e-5
        dM = [(mass_matrix(q + h * e) - mass_matrix(q - h * e)) / (2 * h) for e in np.eye(2)]
        dU = np.array([(potential(q + h * e) - potential(q - h * e)) / (2 * h) for e in np.eye(2)])
        Mdot = dM[0] * qd[0] + dM[1] * qd[1]
        lagrange = mass_matrix(q) @ qdd + Mdot @ qd - 0.5 * np.array([qd @ dM[k] @ qd for k in range(2)]) + dU
        lagrange -= np.array(joint_torques(ARM, theta1, theta2, force[0], force[1]))
        tau1, tau2, _, _ = solve_all_contacts(bodies, q, qd, qdd, gravity, force)
        np.testing.assert_allclose([tau1, tau2], lagrange, rtol=1e-5, atol=1e-6)


def test_base_parameters_are_the_derived_ten():
    base = base_parameters(ARM)
    assert len(base.columns) == 10
    r = ARM.l2 / ARM.l1
    expected = {  # docs/dynamics.md: the identifiable combinations
        "outer1.hx": {"outer1.hx": 1, "l4.m": ARM.l1, "l3.I": 1 / ARM.l1},
        "outer1.hy": {"outer1.hy": 1},
        "outer2.hx": {"outer2.hx": 1, "l3.m": ARM.l2, "l4.I": 1 / ARM.l2},
        "outer2.hy": {"outer2.hy": 1},
        "l4.hx": {"l4.hx": 1, "l3.hx": r},
        "l4.hy": {"l4.hy": 1, "l3.hy": -r},
    }
    found = {PARAMETERS[c]: row for c, row in zip(base.columns, base.K)}
    for lead, combination in expected.items():
        row = found.get(lead)
        if row is None:  # the pivot may have picked another member of the same combination
            row = next(k for k in base.K if all(abs(k[PARAMETERS.index(p)]) > 0 for p in combination))
        lead_value = row[PARAMETERS.index(next(iter(combination)))]
        for name, coefficient in combination.items():
            assert row[PARAMETERS.index(name)] == pytest.approx(coefficient * lead_value, rel=1e-9)
    for name in ("outer1.m", "outer1.I", "outer2.m", "outer2.I"):  # invisible to both cells without gravity
        assert not np.any(base.K[:, PARAMETERS.index(name)])
    rng = np.random.default_rng(5)
    states = random_states(rng, 300)
    pi = parameter_vector(ARM, random_parameters(rng), gravity=(0.5, -1.0))
    Y = shear_regressor(ARM, *states)
    np.testing.assert_allclose(Y[..., list(base.columns)] @ base.of(pi), Y @ pi, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(Y @ base.full(base.of(pi)), Y @ pi, rtol=1e-10, atol=1e-12)
    assert all(isinstance(n, str) and n for n in base.names)


def test_gravity_coefficients_are_linear_in_gravity():
    rng = np.random.default_rng(6)
    params = random_parameters(rng)
    g1, g2 = rng.normal(size=2), rng.normal(size=2)
    np.testing.assert_allclose(gravity_coefficients(ARM, params, g1 + 2 * g2),
                               gravity_coefficients(ARM, params, g1) + 2 * gravity_coefficients(ARM, params, g2),
                               rtol=1e-12, atol=1e-14)  # fmt: skip


def test_prior_from_the_robot_file(tmp_path):
    """Uniform bars: l3's mass, first moment and inertia in closed form, the handle on top; outer parts split at the cell."""
    from sailforce.io.robotfile import load_robot_file
    from sailforce.motion.dynamics import inertial_parameters

    (tmp_path / "r.toml").write_text(
        "[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[handle]\nmass = 1.0\nposition = 1.0\n"
        "[plane]\ntilt_deg = 5\naxis_deg = -90\n"
    )
    robot = load_robot_file(tmp_path / "r.toml").robot
    params = inertial_parameters(robot)
    section, rho = robot.link_section, robot.link_material.rho
    lam = rho * section.depth * section.thickness
    m3 = lam * 0.45
    assert params.l3.m == pytest.approx(m3 + 1.0, rel=1e-12)
    assert params.l3.hx == pytest.approx(m3 * 0.225 + 1.0 * 0.45, rel=1e-12)
    assert params.l3.I == pytest.approx(m3 * (0.45**2 / 3 + section.depth**2 / 12) + 0.45**2, rel=1e-12)
    cell = robot.loadcell
    cell_mass = cell.material.rho * cell.block.depth * cell.block.thickness * cell.length / 2
    assert params.outer1.m == pytest.approx(cell_mass + lam * (0.1 - cell.length / 2), rel=1e-12)
    gx, gy = robot.plane.gravity
    assert gx == pytest.approx(0.0, abs=1e-15) and gy == pytest.approx(-9.80665 * np.sin(np.radians(5)), rel=1e-12)
    # at rest with the links along +x, gravity along -y loads each cell with docs/dynamics.md's combination
    coefficients = gravity_coefficients(robot.arm, params, robot.plane.gravity)
    expected = [(params.outer1.m + params.l4.m + params.l3.hx / 0.2) * gy, 0.0,
                (params.outer2.m + params.l3.m + params.l4.hx / 0.3) * gy, 0.0]  # fmt: skip
    np.testing.assert_allclose(coefficients, expected, rtol=1e-12, atol=1e-12)
