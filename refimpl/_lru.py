"""A bounded least-recently-used map for caches whose values are built from a key by a callable."""

from __future__ import annotations

from collections import OrderedDict
from typing import Callable, Hashable, TypeVar

__all__ = ["LRU"]

V = TypeVar("V")


class LRU:
    """At most ``maxsize`` entries; :meth:`get` builds a missing value with ``make()`` and drops the
    least recently used entry beyond ``maxsize``."""

    def __init__(self, maxsize: int):
        if maxsize < 1:
            raise ValueError(f"maxsize must be >= 1, got {maxsize}")
        self.maxsize = maxsize
        self._data: OrderedDict = OrderedDict()

    def get(self, key: Hashable, make: Callable[[], V]) -> V:
        try:
            value = self._data[key]
        except KeyError:
            value = self._data[key] = make()
            if len(self._data) > self.maxsize:
                self._data.popitem(last=False)
            return value
        self._data.move_to_end(key)
        return value

    def __iter__(self):
        return iter(list(self._data))

    def values(self) -> list:
        return list(self._data.values())

    def __len__(self) -> int:
        return len(self._data)

    def clear(self) -> None:
        self._data.clear()
