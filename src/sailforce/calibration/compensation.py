"""Moved to :mod:`sailforce.sensing.maps`, :mod:`sailforce.estimate.estimator` and :mod:`sailforce.fit.matrix`.

This path works for one release, with a warning.
"""

from .._moved import moved

__getattr__ = moved(__name__, "sailforce.sensing.maps", "sailforce.estimate.estimator", "sailforce.fit.matrix")
