"""Package re-exports that import their module on first use, so that ``import sailforce.x.y`` stays as cheap as it was.

A package's ``__init__`` lists its public names by module::

    __all__, __getattr__, __dir__ = lazy_exports(__name__, {"model": ("ArmModel", "build_model")})

and ``from sailforce.fem import build_model`` imports ``sailforce.fem.model``
then.  The names are checked against the modules by ``tests/test_api.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module


def lazy_exports(package: str, modules: dict[str, tuple[str, ...]]) -> tuple[list[str], Callable[[str], object], Callable[[], list[str]]]:
    """``__all__``, ``__getattr__`` and ``__dir__`` of ``package``, whose ``modules`` (relative names) hold the names listed."""
    where = {name: module for module, names in modules.items() for name in names}
    public = sorted(where)

    def __getattr__(name: str) -> object:
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(f"{package}.{where[name]}"), name)
        globals_of(package)[name] = value  # the next lookup is a plain attribute
        return value

    def __dir__() -> list[str]:
        return sorted(set(globals_of(package)) | set(public))

    return public, __getattr__, __dir__


def globals_of(package: str) -> dict:
    import sys

    return vars(sys.modules[package])
