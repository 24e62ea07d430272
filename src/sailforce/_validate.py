"""Boundary checks: turn arguments into float arrays, or say exactly why not."""

from __future__ import annotations

import numpy as np

from .errors import NonFiniteInputError, ShapeError


def as_float_arrays(**named: object) -> tuple[np.ndarray, ...]:
    """Convert each named argument to a float64 array and broadcast them together.

    Raises :class:`ShapeError` if the shapes do not broadcast and
    :class:`NonFiniteInputError` if any value is NaN or infinite, naming the
    argument and the first bad index.

    >>> a, b = as_float_arrays(theta1=[0.0, 1.0], theta2=0.5)
    >>> b
    array([0.5, 0.5])
    """
    arrays = []
    for name, value in named.items():
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ShapeError(f"{name}: expected numbers, got {type(value).__name__} ({exc})") from None
        if not _all_finite(array):
            bad = np.argwhere(~np.isfinite(array))[0]
            where = f" at index {tuple(int(i) for i in bad)}" if array.ndim else ""
            raise NonFiniteInputError(
                f"{name}: expected finite numbers, got {float(array[tuple(bad)])!r}{where}"
            )
        arrays.append(array)
    try:
        return tuple(np.broadcast_arrays(*arrays))
    except ValueError:
        shapes = ", ".join(f"{n} {a.shape}" for n, a in zip(named, arrays))
        raise ShapeError(f"arguments do not broadcast together: {shapes}") from None


def _all_finite(array: np.ndarray) -> bool:
    # A sum is finite only if every term is, barring overflow; the sum costs one
    # pass without a temporary, so check it first and look closer only on doubt.
    if np.isfinite(np.add.reduce(array, axis=None)):
        return True
    return bool(np.all(np.isfinite(array)))



