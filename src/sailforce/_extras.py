"""Optional dependencies: the ``report`` and ``serial`` extras, imported when first needed, with an error for people."""

from __future__ import annotations

import importlib
from types import ModuleType

from .errors import MissingExtraError


def require(module: str, extra: str, feature: str) -> ModuleType:
    """Import ``module``, or say which extra of sailforce brings it: ``pip install 'sailforce[extra]'``."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(f"{feature} needs the Python package {module!r}, which is not installed; "
                                f"install sailforce's {extra!r} extra: pip install 'sailforce[{extra}]'") from None
