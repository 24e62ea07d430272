"""The solid's cache of poses: a :class:`~sailforce.io.cache.DiskCache` with the solid's entry format."""

from __future__ import annotations

from dataclasses import dataclass

from ..io.cache import ENTRY_FORMAT, DiskCache, _canonical, cache_key

__all__ = ["SolidCache", "_canonical", "cache_key"]


@dataclass
class SolidCache(DiskCache):
    """The solid's cache folder (None: no cache): entries in the ``sailforce-solid-cache`` format."""

    entry_format: str = ENTRY_FORMAT
