"""Rigid-body dynamics of the parallelogram: what the load cells read while the arm moves.

The seed's method is static.  While the arm moves, each cell also carries
the inertial and gravity loads of the bodies beyond it:

- ``outer1``: l1 from cell 1's centre ``c1 = s l1 u1`` to P1, turning with theta1 about B;
- ``outer2``: l2 from cell 2's centre to P2, turning with theta2 about B;
- ``l4``: P1 to P3, parallel to l2 (it turns with theta2 while P1 moves with theta1);
- ``l3``: P2 through P3 to A with the handle, parallel to l1 (turns with theta1, P2 moves with theta2).

``u_i = (cos theta_i, sin theta_i)``; ``a x b = a_x b_y - a_y b_x``.  Pins at
P1, P2 and P3 carry forces only.  Each body b has four **inertial
parameters** about a reference point ``O_b`` fixed in it (B, B, P1, P2), in
a frame whose x axis is the body's own direction: mass ``m``, first moment
``h = m r_G`` (x, y) and rotational inertia ``I`` about ``O_b``.  Newton and
Euler for body b, with ``a_O`` the acceleration of ``O_b`` and ``g`` the
in-plane gravity (Featherstone, *Rigid Body Dynamics Algorithms*, 2008,
Sec. 2.11, in the plane)::

    f_b = m (a_O - g) + alpha k x (R h) - omega^2 R h          (net contact force)
    n_b = I alpha + (R h) x (a_O - g)                          (net contact moment about O_b)

Cutting the loop at both cells leaves a chain whose pin forces follow from
the moment equations of l4 about P1 and of l3 about P2.  The **cell shear**
``V_i``, the force the outer part exerts on the inner part, across the link
(``u_i x``), positive as ``T_i / l_i``, is then (derivation in
``docs/dynamics.md``)::

    V1 = (l3 u1 x F - n3) / l1 - u1 x f_outer1 - u1 x f4        (D1)
    V2 = u2 x F - n4 / l2 - u2 x f_outer2 - u2 x f3             (D2)

At rest without gravity ``V_i = T_i / l_i`` exactly, with ``T = J^T F``
(seed Eq. 3): the static limit of ``sailforce.statics``.

**Regressor form.**  ``V`` is linear in the 16 inertial parameters (for
fixed gravity) and its gravity part is ``g1c cos theta1 + g1s sin theta1``
for cell 1 and ``g2c cos theta2 + g2s sin theta2`` for cell 2.  So
``V = Y(q, qd, qdd) pi + V_static(F)`` with ``pi`` the 16 inertial parameters
(gravity off) followed by the 4 gravity coefficients, :data:`PARAMETERS`.
Only 10 combinations of them are identifiable from the cells
(:func:`base_parameters` finds them numerically).
"""

from __future__ import annotations

from dataclasses import astuple, dataclass, fields

import numpy as np

from .._validate import as_float_arrays
from ..errors import DynamicsError
from ..kinematics import Links

BODIES = ("outer1", "outer2", "l4", "l3")
BODY_PARAMETERS = ("m", "hx", "hy", "I")
INERTIAL_PARAMETERS = tuple(f"{b}.{p}" for b in BODIES for p in BODY_PARAMETERS)
GRAVITY_PARAMETERS = ("gravity1.cos", "gravity1.sin", "gravity2.cos", "gravity2.sin")
#: The columns of :func:`shear_regressor`: 16 inertial parameters, then the 4 gravity coefficients [N].
PARAMETERS = INERTIAL_PARAMETERS + GRAVITY_PARAMETERS

#: Singular values below this fraction of the largest count as zero when finding the base parameters:
#: the regressor's entries are O(1) in SI for arm-sized motions, and rounding leaves ~1e-15 relative.
RANK_RTOL = 1e-9



@dataclass(frozen=True)
class BodyInertia:
    """One rigid body's inertial parameters about its reference point, in its own frame (SI)."""

    m: float = 0.0  #: [kg]
    hx: float = 0.0  #: [kg m] first moment along the body's direction
    hy: float = 0.0  #: [kg m] first moment across it
    I: float = 0.0  #: [kg m^2] rotational inertia about the reference point  # noqa: E741

    def __add__(self, other: BodyInertia) -> BodyInertia:
        return BodyInertia(*(a + b for a, b in zip(astuple(self), astuple(other))))


@dataclass(frozen=True)
class InertialParameters:
    """The four bodies beyond the cells: ``outer1``, ``outer2`` about B, ``l4`` about P1, ``l3`` about P2."""

    outer1: BodyInertia = BodyInertia()
    outer2: BodyInertia = BodyInertia()
    l4: BodyInertia = BodyInertia()
    l3: BodyInertia = BodyInertia()

    def vector(self) -> np.ndarray:
        """The 16 values in the order of :data:`INERTIAL_PARAMETERS`."""
        return np.array([v for f in fields(self) for v in astuple(getattr(self, f.name))], dtype=float)

    @classmethod
    def from_vector(cls, values) -> InertialParameters:
        values = np.asarray(values, dtype=float).reshape(4, 4)
        return cls(*(BodyInertia(*map(float, row)) for row in values))


def bar(start: float, stop: float, linear_density: float, depth: float) -> BodyInertia:
    """A uniform bar along the body's x axis from ``start`` to ``stop`` [m], of mass per length [kg/m].

    ``depth`` is its in-plane section depth: the bar's own rotary inertia
    about its axis, m depth^2 / 12, adds to the slender-bar term.
    """
    length = stop - start
    m = linear_density * length
    return BodyInertia(m, m * (start + stop) / 2, 0.0,
                       linear_density * (stop**3 - start**3) / 3 + m * depth**2 / 12)  # fmt: skip


def point_mass(mass: float, x: float) -> BodyInertia:
    """A point mass on the body's axis at ``x`` [m] from its reference point."""
    return BodyInertia(mass, mass * x, 0.0, mass * x * x)


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def _rotate(c, s, x, y):
    return c * x - s * y, s * x + c * y


def _body_terms(body: BodyInertia, c, s, omega, alpha, aox, aoy, gx, gy):
    """(f_x, f_y, n) of one body: net contact force and moment about its reference point (module docstring)."""
    hx, hy = _rotate(c, s, body.hx, body.hy)  # R h in the world frame
    ax, ay = aox - gx, aoy - gy
    fx = body.m * ax - alpha * hy - omega * omega * hx
    fy = body.m * ay + alpha * hx - omega * omega * hy
    return fx, fy, body.I * alpha + _cross(hx, hy, ax, ay)


def cell_shears(arm: Links, params: InertialParameters, theta1, theta2, omega1=0.0, omega2=0.0, alpha1=0.0,
                alpha2=0.0, *, gravity=(0.0, 0.0), fx=0.0, fy=0.0) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The cells' shears ``(V1, V2)`` [N] by Newton-Euler, Eqs. D1-D2; batched over any broadcastable shape.

    Angles [rad], rates [rad/s], accelerations [rad/s^2]; ``gravity`` the
    in-plane gravity vector [m/s^2]; ``fx, fy`` the hand's force on the
    handle at A [N].  With no motion and no gravity, ``V_i = T_i / l_i``.
    """
    theta1, theta2, omega1, omega2, alpha1, alpha2, fx, fy = as_float_arrays(
        theta1=theta1, theta2=theta2, omega1=omega1, omega2=omega2, alpha1=alpha1, alpha2=alpha2, fx=fx, fy=fy)
    gx, gy = (float(v) for v in gravity)
    c1, s1, c2, s2 = np.cos(theta1), np.sin(theta1), np.cos(theta2), np.sin(theta2)
    # accelerations of the reference points: B is fixed; P1 = l1 u1; P2 = l2 u2
    p1x, p1y = arm.l1 * (-alpha1 * s1 - omega1**2 * c1), arm.l1 * (alpha1 * c1 - omega1**2 * s1)
    p2x, p2y = arm.l2 * (-alpha2 * s2 - omega2**2 * c2), arm.l2 * (alpha2 * c2 - omega2**2 * s2)
    fo1x, fo1y, _ = _body_terms(params.outer1, c1, s1, omega1, alpha1, 0.0, 0.0, gx, gy)
    fo2x, fo2y, _ = _body_terms(params.outer2, c2, s2, omega2, alpha2, 0.0, 0.0, gx, gy)
    f4x, f4y, n4 = _body_terms(params.l4, c2, s2, omega2, alpha2, p1x, p1y, gx, gy)
    f3x, f3y, n3 = _body_terms(params.l3, c1, s1, omega1, alpha1, p2x, p2y, gx, gy)
    v1 = (arm.l3 * _cross(c1, s1, fx, fy) - n3) / arm.l1 - _cross(c1, s1, fo1x, fo1y) - _cross(c1, s1, f4x, f4y)
    v2 = _cross(c2, s2, fx, fy) - n4 / arm.l2 - _cross(c2, s2, fo2x, fo2y) - _cross(c2, s2, f3x, f3y)
    return v1, v2


def gravity_coefficients(arm: Links, params: InertialParameters, gravity) -> np.ndarray:
    """The 4 gravity coefficients [N] of :data:`GRAVITY_PARAMETERS` for these bodies in this gravity."""
    # At rest, cell 1's gravity load depends on theta1 alone and cell 2's on theta2 alone (Eqs. D1-D2),
    # so their values at 0 and 90 degrees are the cosine and sine coefficients.
    angles = np.array([0.0, np.pi / 2])
    cell1, _ = cell_shears(arm, params, angles, angles + 1.0, gravity=gravity)
    _, cell2 = cell_shears(arm, params, angles + 1.0, angles, gravity=gravity)
    return np.concatenate([cell1, cell2])


def parameter_vector(arm: Links, params: InertialParameters, gravity=(0.0, 0.0)) -> np.ndarray:
    """The 20 values of :data:`PARAMETERS` for these bodies in this in-plane gravity."""
    return np.concatenate([params.vector(), gravity_coefficients(arm, params, gravity)])


def shear_regressor(arm: Links, theta1, theta2, omega1, omega2, alpha1, alpha2) -> np.ndarray:
    """``Y`` of shape ``(..., 2, 20)``: the cells' dynamic shears are ``Y @ parameter_vector(...)`` [N].

    Row 0 is cell 1, row 1 cell 2; columns follow :data:`PARAMETERS`.  The
    entries are Eqs. D1-D2 with one parameter set to 1 and the others to 0
    (V is linear in each), written out; ``tests/test_dynamics.py`` checks
    them against :func:`cell_shears`.
    """
    theta1, theta2, w1, w2, a1, a2 = as_float_arrays(
        theta1=theta1, theta2=theta2, omega1=omega1, omega2=omega2, alpha1=alpha1, alpha2=alpha2)
    l1, l2 = arm.l1, arm.l2
    delta = theta1 - theta2
    cd, sd = np.cos(delta), np.sin(delta)
    zero = np.zeros_like(delta)
    # the two motion patterns that l4 and l3 share: cell 1 sees theta2's motion, cell 2 theta1's
    across2 = a2 * cd + w2 * w2 * sd  # x-moments in cell 1
    along2 = -a2 * sd + w2 * w2 * cd  # y-moments in cell 1
    across1 = a1 * cd - w1 * w1 * sd  # x-moments in cell 2
    along1 = a1 * sd + w1 * w1 * cd  # y-moments in cell 2
    row1 = [zero, -a1, w1 * w1, zero,                          # outer1
            zero, zero, zero, zero,                            # outer2
            -l1 * a1, -across2, along2, zero,                  # l4
            zero, -l2 / l1 * across2, -l2 / l1 * along2, -a1 / l1,  # l3
            np.cos(theta1), np.sin(theta1), zero, zero]  # fmt: skip
    row2 = [zero, zero, zero, zero,
            zero, -a2, w2 * w2, zero,
            zero, -l1 / l2 * across1, -l1 / l2 * along1, -a2 / l2,
            -l2 * a2, -across1, along1, zero,
            zero, zero, np.cos(theta2), np.sin(theta2)]  # fmt: skip
    return np.stack([np.stack(row1, axis=-1), np.stack(row2, axis=-1)], axis=-2)


#: What each of :class:`ShearModel`'s six coefficients per cell multiplies.
SHEAR_TERMS = ("alpha_own", "omega_own^2", "across_other", "along_other", "cos_own", "sin_own")


@dataclass(frozen=True)
class ShearModel:
    """The dynamic shears in closed form: six coefficients per cell, grouped from a parameter vector.

    With ``a = across``, ``b = along`` the other link's motion patterns of
    :func:`shear_regressor` (``a2 = alpha2 cos d + omega2^2 sin d``,
    ``b2 = -alpha2 sin d + omega2^2 cos d``, ``a1 = alpha1 cos d - omega1^2 sin d``,
    ``b1 = alpha1 sin d + omega1^2 cos d``, ``d = theta1 - theta2``)::

        V1 = k1[0] alpha1 + k1[1] omega1^2 + k1[2] a2 + k1[3] b2 + k1[4] cos theta1 + k1[5] sin theta1
        V2 = k2[0] alpha2 + k2[1] omega2^2 + k2[2] a1 + k2[3] b1 + k2[4] cos theta2 + k2[5] sin theta2

    which is ``Y @ pi`` with Y's entries collected term by term (Eqs. D1-D2;
    ``tests/test_dynamics.py`` checks the identity).  Twelve numbers carry
    every identifiable parameter: what libsail stores.
    """

    coefficients: tuple[tuple[float, ...], tuple[float, ...]]  #: (2, 6) in :data:`SHEAR_TERMS` order [N per unit]

    @classmethod
    def from_parameters(cls, arm: Links, pi) -> ShearModel:
        p = np.asarray(pi, dtype=float)
        if p.shape != (len(PARAMETERS),):
            raise DynamicsError(f"a parameter vector has {len(PARAMETERS)} entries ({', '.join(PARAMETERS)}), not {p.shape}")
        l1, l2 = arm.l1, arm.l2
        k1 = (-(p[1] + l1 * p[8] + p[15] / l1), p[2], -(p[9] + l2 / l1 * p[13]), p[10] - l2 / l1 * p[14], p[16], p[17])
        k2 = (-(p[5] + p[11] / l2 + l2 * p[12]), p[6], -(l1 / l2 * p[9] + p[13]), p[14] - l1 / l2 * p[10], p[18], p[19])
        return cls((tuple(float(v) for v in k1), tuple(float(v) for v in k2)))

    def shears(self, theta1, theta2, omega1, omega2, alpha1, alpha2) -> np.ndarray:
        """``(..., 2)``: the cells' dynamic shears [N] (angles [rad], rates [rad/s], accelerations [rad/s^2])."""
        theta1, theta2 = np.asarray(theta1, dtype=float), np.asarray(theta2, dtype=float)
        v1, v2 = self.shears_from_trig(np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2),
                                       omega1, omega2, alpha1, alpha2)  # fmt: skip
        return np.stack([v1, v2], axis=-1)

    def shears_from_trig(self, sin1, cos1, sin2, cos2, omega1, omega2, alpha1, alpha2) -> tuple[np.ndarray, np.ndarray]:
        """``(V1, V2)`` from the joint angles' sines and cosines (as the estimator has them), in place where it can.

        ``sin(delta)`` and ``cos(delta)`` come from the angle-difference
        identities, as in libsail's ``sail_estimate_moving``.
        """
        (a, b, c, d, e, f), (g, h, i, j, k, m) = self.coefficients
        sd = sin1 * cos2
        sd -= cos1 * sin2
        cd = cos1 * cos2
        cd += sin1 * sin2
        w1, w2 = np.square(omega1), np.square(omega2)
        # V1 = a α1 + b w1 + c (α2 cd + w2 sd) + d (w2 cd - α2 sd) + e cos θ1 + f sin θ1  (docs/dynamics.md, Eq. D1)
        #    = a α1 + b w1 + (c cd - d sd) α2 + (c sd + d cd) w2 + e cos θ1 + f sin θ1
        v1 = a * alpha1
        v1 += b * w1
        v1 += (c * cd - d * sd) * alpha2
        v1 += (c * sd + d * cd) * w2
        v1 += e * cos1
        v1 += f * sin1
        # V2 = g α2 + h w2 + i (α1 cd - w1 sd) + j (α1 sd + w1 cd) + k cos θ2 + m sin θ2  (Eq. D2)
        #    = g α2 + h w2 + (i cd + j sd) α1 + (j cd - i sd) w1 + k cos θ2 + m sin θ2
        v2 = g * alpha2
        v2 += h * w2
        v2 += (i * cd + j * sd) * alpha1
        v2 += (j * cd - i * sd) * w1
        v2 += k * cos2
        v2 += m * sin2
        return v1, v2


@dataclass(frozen=True)
class BaseParameters:
    """The identifiable combinations of :data:`PARAMETERS`: ``beta = K @ pi``.

    ``columns`` are the independent regressor columns that represent them;
    ``K`` (rank x 20) maps any full parameter vector to its base parameters,
    and ``Y[..., columns] @ beta`` equals ``Y @ pi`` for every motion.
    """

    columns: tuple[int, ...]
    K: np.ndarray

    @property
    def names(self) -> tuple[str, ...]:
        """Each base parameter written out, e.g. ``outer1.hx + 0.2 l4.m + 5 l3.I``."""
        out = []
        for row in self.K:
            terms = [f"{'+' if c > 0 else '-'} {'' if np.isclose(abs(c), 1.0) else f'{abs(c):.6g} '}{PARAMETERS[j]}"
                     for j, c in enumerate(row) if abs(c) > 1e-12]  # fmt: skip
            text = " ".join(terms)
            out.append(text[2:] if text.startswith("+ ") else "-" + text[2:])
        return tuple(out)

    def of(self, pi) -> np.ndarray:
        """The base parameters of a full parameter vector ``pi`` (20,)."""
        return self.K @ np.asarray(pi, dtype=float)

    def full(self, beta) -> np.ndarray:
        """A full parameter vector (20,) with the base parameters ``beta`` in their columns, zeros elsewhere."""
        pi = np.zeros(len(PARAMETERS))
        pi[list(self.columns)] = beta
        return pi


def stacked_regressor(arm: Links, theta1, theta2, omega1, omega2, alpha1, alpha2) -> np.ndarray:
    """``(2 N, 20)``: :func:`shear_regressor` of N samples, cell 1's rows then cell 2's."""
    Y = shear_regressor(arm, *(np.ravel(a) for a in (theta1, theta2, omega1, omega2, alpha1, alpha2)))
    return np.concatenate([Y[:, 0, :], Y[:, 1, :]])


def base_parameters(arm: Links, *, samples: int = 2000, seed: int = 0) -> BaseParameters:
    """The base parameters of ``arm``, from a QR factorisation with column pivoting of a rich random regressor.

    Random poses, rates and accelerations excite every column that can be
    excited; a column whose part independent of the pivot columns falls below
    :data:`RANK_RTOL` is a combination of them.  The structure found is the
    arm's, not the motion's (``tests/test_dynamics.py`` checks it against
    the hand derivation in ``docs/dynamics.md``).
    """
    from scipy.linalg import qr

    rng = np.random.default_rng(seed)
    theta2 = rng.uniform(-np.pi, np.pi, samples)
    motion = rng.normal(size=(4, samples)) * 3.0
    W = stacked_regressor(arm, theta2 + rng.uniform(0.2, np.pi - 0.2, samples), theta2, *motion)
    scale = np.linalg.norm(W, axis=0)
    live = scale > RANK_RTOL * scale.max()
    _, r, perm = qr(W[:, live] / scale[live], mode="economic", pivoting=True)
    diag = np.abs(np.diag(r))
    rank = int(np.count_nonzero(diag > RANK_RTOL * diag[0]))
    live_index = np.flatnonzero(live)
    independent = live_index[perm[:rank]]
    # beta = K pi with Y[:, independent] K = Y: least squares, exact for a consistent structure
    K, *_ = np.linalg.lstsq(W[:, independent], W, rcond=None)
    K[np.abs(K) < 1e-12] = 0.0
    order = np.argsort(independent)
    return BaseParameters(tuple(int(i) for i in independent[order]), K[order])


def inertial_parameters(robot) -> InertialParameters:
    """The robot file's prior: uniform bars of the links' and cells' sections and densities, and the handle.

    ``outer_i`` is half the cell block from the cell's centre, then the link
    to its far end; l4 and l3 are whole links; the handle is a point mass on
    l3.  Joint hardware is not modelled: identify the real values from a
    free-motion recording (``sail calibrate --free-motion``).
    """
    arm, cell = robot.arm, robot.loadcell
    cell_density = cell.material.rho * cell.block.depth * cell.block.thickness

    def link(name: str, start: float, end: float) -> BodyInertia:
        section = robot.section(name)
        return bar(start, end, robot.material(name).rho * section.area, section.depth)

    def outer(name: str, length: float) -> BodyInertia:
        centre = cell.position * length
        return (bar(centre, centre + cell.length / 2, cell_density, cell.block.depth)
                + link(name, centre + cell.length / 2, length))  # fmt: skip

    handle = point_mass(robot.handle.mass, robot.handle.position * arm.l3)
    return InertialParameters(outer("l1", arm.l1), outer("l2", arm.l2), link("l4", 0.0, arm.l2),
                              link("l3", 0.0, arm.l3) + handle)  # fmt: skip
