"""Polynomial regressors chosen by goodness of fit, as the seed fitted Table 4.

The seed (Section 3, after Table 4) fits each column of Table 4 against
delta with "the minimum polynomial order resulting in an adjusted R^2 >
0.999".  That rule reproduces its A1, P1 and P2; its published A2 is the
order-4 fit, whose plain R^2 (0.99919) passes but whose adjusted R^2
(0.99810) does not, so A2 follows a plain-R^2 rule (docs/errata.md).  Both
criteria are offered here and every fit says which one chose it.

Coefficients are stored highest power first, as the seed prints them and as
:func:`numpy.polyval` takes them.  Fits are computed in a scaled domain
(:meth:`numpy.polynomial.Polynomial.fit`) and converted, so orders up to the
number of points minus two stay well conditioned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import RegressorError

CRITERIA = ("adj-r2", "r2")
DEFAULT_CRITERION = "adj-r2"  #: the rule the seed states
DEFAULT_THRESHOLD = 0.999  #: the seed's threshold on (adjusted) R^2

#: A column whose spread is below this fraction of its magnitude is constant:
#: R^2 = SS_res/SS_tot is then a ratio of rounding errors, so it is taken as
#: 1 (any polynomial fits).  The pin-joint study's Table 4 is constant to
#: ~1e-12 relative (FE rounding); real variation is never below 1e-9.
CONSTANT_RTOL = 1e-9
#: ... or whose spread is below this, in its own units: the pin-joint phases
#: are zero to ~1e-12 deg, and Table 4 is printed to 1e-3.
CONSTANT_ATOL = 1e-9



@dataclass(frozen=True)
class PolynomialFit:
    """One column's regressor y = polyval(coefficients, x).

    ``passed`` says whether ``criterion`` exceeded ``threshold`` at this
    order; a fit that never passes is the highest order tried, kept so the
    caller can report it rather than lose it.
    """

    order: int
    coefficients: tuple[float, ...]  #: highest power first
    r2: float
    adj_r2: float
    criterion: str
    threshold: float
    passed: bool

    def __call__(self, x) -> np.ndarray:
        return np.polyval(self.coefficients, np.asarray(x, dtype=float))

    def as_dict(self) -> dict[str, object]:
        """The JSON form: ``order``, ``coefficients`` (highest power first), ``r2``, ``adj_r2`` and the rule."""
        return {
            "order": self.order,
            "coefficients": list(self.coefficients),
            "r2": self.r2,
            "adj_r2": self.adj_r2,
            "criterion": self.criterion,
            "threshold": self.threshold,
            "passed": self.passed,
        }


def r_squared(y: np.ndarray, fitted: np.ndarray) -> float:
    """Coefficient of determination 1 - SS_res / SS_tot."""
    residual = y - fitted
    centred = y - y.mean()
    total = float(centred @ centred)
    if np.ptp(y) <= max(CONSTANT_RTOL * np.max(np.abs(y), initial=0.0), CONSTANT_ATOL):
        return 1.0
    return 1.0 - float(residual @ residual) / total


def adjusted_r_squared(r2: float, n: int, order: int) -> float:
    """Adjusted R^2 = 1 - (1 - R^2)(n - 1)/(n - p - 1) for p = ``order`` regressors.

    Needs n > p + 1; one point more than the parameters leaves no residual
    degree of freedom, and there it is undefined.
    """
    dof = n - order - 1
    if dof <= 0:
        raise RegressorError(f"adjusted R^2 needs more points than order + 1 = {order + 1}, got {n}")
    return 1.0 - (1.0 - r2) * (n - 1) / dof


def fit_polynomial(x, y, order: int, criterion: str = DEFAULT_CRITERION, threshold: float = DEFAULT_THRESHOLD) -> PolynomialFit:
    """Least-squares polynomial of ``order`` through (x, y), with its R^2 and adjusted R^2."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    polynomial = np.polynomial.Polynomial.fit(x, y, order).convert()
    coefficients = np.zeros(order + 1)
    coefficients[: polynomial.coef.size] = polynomial.coef  # convert() drops exact trailing zeros
    r2 = r_squared(y, polynomial(x))
    adj = adjusted_r_squared(r2, x.size, order)
    score = adj if criterion == "adj-r2" else r2
    return PolynomialFit(order, tuple(float(c) for c in coefficients[::-1]), r2, adj, criterion, threshold, score > threshold)


def select_order(
    x,
    y,
    *,
    criterion: str = DEFAULT_CRITERION,
    threshold: float = DEFAULT_THRESHOLD,
    max_order: int | None = None,
) -> PolynomialFit:
    """The lowest-order polynomial whose ``criterion`` exceeds ``threshold``.

    ``max_order`` defaults to n - 2, the highest order at which adjusted R^2
    is defined.  When no order up to it passes, the ``max_order`` fit is
    returned with ``passed = False``.

    >>> delta = [15, 30, 45, 60, 75, 90, 105, 120]
    >>> p2 = [-0.544, -7.413, -13.673, -19.569, -25.124, -30.322, -34.924, -38.826]
    >>> fit = select_order(delta, p2)          # seed Table 4, load cell 2 phase
    >>> fit.order, [float(f"{c:.4g}") for c in fit.coefficients]
    (2, [0.0009927, -0.4999, 6.749])
    """
    if criterion not in CRITERIA:
        raise RegressorError(f"criterion = {criterion!r}: expected one of {', '.join(CRITERIA)}")
    if not 0.0 < threshold < 1.0:
        raise RegressorError(f"threshold = {threshold!r}: expected a number between 0 and 1")
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = x.size
    highest = n - 2 if max_order is None else int(max_order)
    if highest < 0:
        raise RegressorError(f"max order {highest} is negative")
    if n < highest + 2:
        raise RegressorError(
            f"{n} rows cannot support order {highest}: a polynomial of order p needs at least p + 2 rows "
            "for adjusted R^2; lower --max-order or add rows"
        )
    if np.unique(x).size <= highest:
        raise RegressorError(f"only {np.unique(x).size} distinct x values for order {highest}")
    fit = None
    fit = fit_polynomial(x, y, 0, criterion, threshold)
    for order in range(1, highest + 1):
        if fit.passed:
            return fit
        fit = fit_polynomial(x, y, order, criterion, threshold)
    return fit
