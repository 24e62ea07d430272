"""Old import paths that moved, kept working for one release with a warning.

A module that moved leaves behind a two-line stand-in at its old path::

    from .._moved import moved
    __getattr__ = moved(__name__, "sailforce.sensing.maps", "sailforce.fit.matrix")

Importing it warns (:class:`DeprecationWarning`) once, and each name is
looked up in the new modules in order (PEP 562), so ``from old import name``
keeps working.  Nothing in sailforce imports a stand-in
(``tests/test_layout.py`` checks it).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from importlib import import_module


def moved(old: str, *new: str) -> Callable[[str], object]:
    """Warn that ``old`` moved to ``new``, and return the stand-in module's ``__getattr__``."""
    warnings.warn(f"{old} has moved to {' and '.join(new)}; import from there (or from the package's public names). "
                  "The old path works for one release.", DeprecationWarning, stacklevel=3)  # fmt: skip

    def __getattr__(name: str) -> object:
        for target in new:
            module = import_module(target)
            if hasattr(module, name):
                return getattr(module, name)
        raise AttributeError(f"module {old!r} (moved to {', '.join(new)}) has no attribute {name!r}")

    return __getattr__
