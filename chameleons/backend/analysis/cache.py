"""A small in-process cache of finished analyses, keyed by what went into them.

The effect sizes (bootstrap) and the models take most of a second for a large study; the
analysis page's sections, its JSON and its LaTeX download ask for the same analysis in
quick succession. The key holds a digest of the input rows, so new data is never served
stale: a changed row is a different key.
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, TypeVar

T = TypeVar("T")
MAX_ENTRIES = 16


def digest(*parts: Any) -> str:
    """A stable digest of JSON-able inputs (rows of numbers and strings)."""
    text = json.dumps(parts, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


class ResultCache:
    def __init__(self, max_entries: int = MAX_ENTRIES) -> None:
        self._entries: OrderedDict[Hashable, Any] = OrderedDict()
        self._lock = threading.Lock()
        self._max = max_entries

    def get_or_compute(self, key: Hashable, compute: Callable[[], T]) -> T:
        with self._lock:
            if key in self._entries:
                self._entries.move_to_end(key)
                return self._entries[key]  # type: ignore[no-any-return]
        value = compute()  # outside the lock: two requests may compute, neither waits
        with self._lock:
            self._entries[key] = value
            while len(self._entries) > self._max:
                self._entries.popitem(last=False)
        return value

    def get(self, key: Hashable) -> Any:
        """The cached value, or None."""
        with self._lock:
            if key not in self._entries:
                return None
            self._entries.move_to_end(key)
            return self._entries[key]

    def put(self, key: Hashable, value: Any) -> None:
        with self._lock:
            self._entries[key] = value
            while len(self._entries) > self._max:
                self._entries.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()


analyses = ResultCache()
# Whole results of the analysis page, keyed by the data version (:mod:`.repository`): the
# first render's and the effect sizes' of the view last asked for. They hold their rows
# (about 90 MB each for 1,000 participants, 9 MB for 100), so two.
page_results = ResultCache(max_entries=2)


def clear_all() -> None:
    """Forget every cached analysis (a withdrawal: its rows must not outlive it here)."""
    analyses.clear()
    page_results.clear()
