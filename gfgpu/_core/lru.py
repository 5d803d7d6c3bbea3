"""A bounded, thread-safe table of values made on a miss (least recently used dropped first):
the caches of plans, windows and small device arrays that calls at one shape share."""

from __future__ import annotations

import threading
from collections import OrderedDict

__all__ = ["LRU"]

_MISSING = object()


class LRU:
    """At most ``most`` entries; :meth:`get` makes a missing one with ``make()`` outside the lock
    (two threads may both make it: the values must be equal, and the last one is kept)."""

    def __init__(self, most):
        if int(most) < 0:
            raise ValueError(f"most must be >= 0, got {most}")
        self.most = int(most)
        self._table = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key, make):
        """``table[key]``, made by ``make()`` on a miss."""
        with self._lock:
            hit = self._table.get(key, _MISSING)
            if hit is not _MISSING:
                self._table.move_to_end(key)
                return hit
        hit = make()
        with self._lock:
            self._table[key] = hit
            while len(self._table) > self.most:
                self._table.popitem(last=False)
        return hit

    def clear(self):
        with self._lock:
            self._table.clear()

    def __len__(self):
        return len(self._table)
