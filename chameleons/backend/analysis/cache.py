"""A small in-process cache of the analysis page's finished results.

The paper's analysis of a large study takes seconds, its effect sizes (bootstrap) and
models more; the page, its sections, its JSON and its LaTeX download ask for the same
results in quick succession, and a PI comes back to an unchanged study. The key holds the
study's data version (:mod:`.repository`), so new data is never served stale: any change
is a different key.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Hashable
from typing import Any

MAX_ENTRIES = 16  # a ResultCache's default


class ResultCache:
    def __init__(self, max_entries: int = MAX_ENTRIES) -> None:
        self._entries: OrderedDict[Hashable, Any] = OrderedDict()
        self._lock = threading.Lock()
        self._max = max_entries

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


# The first render's and the effect sizes' results of the view last asked for. Each holds
# its rows (about 90 MB for 1,000 participants, 9 MB for 100), so two.
analyses = ResultCache(max_entries=2)
