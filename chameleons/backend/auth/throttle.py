"""Slow down password guessing without letting anyone lock a colleague out.

Failures are counted per (username, source address) pair and per source address. A pair
locks after ``max_failures`` failures in a row, for ``lockout_seconds`` doubling with each
further failure (at most ``MAX_LOCKOUT_SECONDS``); an address that fails on many usernames
(spraying) locks after ``ADDRESS_FACTOR`` times as many. A stranger failing on the PI's
name locks only their own address, never the PI's (OWASP Authentication Cheat Sheet:
"account lockout" can be abused for denial of service; Django-axes locks on
username + address for the same reason). A success clears the pair.

Records live in memory, so they must not pile up: one that has no effect left (quiet for
longer than any lock-out) is dropped when it is next looked at, and a sweep at most once
a ``SWEEP_SECONDS`` drops all such records; above ``max_records`` (many addresses failing
within a lock-out) the oldest go first.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from threading import Lock

MAX_LOCKOUT_SECONDS = 15 * 60.0
ADDRESS_FACTOR = 4
SWEEP_SECONDS = 60.0
MAX_RECORDS = 100_000  # two per failure: argon2 allows a few dozen failures a second


@dataclass
class _Record:
    failures: int = 0
    last: float = 0.0


@dataclass
class LoginThrottle:
    max_failures: int
    lockout_seconds: float
    clock: Callable[[], float] = time.monotonic
    max_records: int = MAX_RECORDS
    _records: dict[str, _Record] = field(default_factory=dict)
    _lock: Lock = field(default_factory=Lock)
    _next_sweep: float = float("-inf")

    def __len__(self) -> int:
        return len(self._records)

    @staticmethod
    def keys(username: str, address: str) -> tuple[str, str]:
        return (f"pair:{username.lower()}|{address}", f"address:{address}")

    def _limit(self, key: str) -> int:
        factor = ADDRESS_FACTOR if key.startswith("address:") else 1
        return self.max_failures * factor

    def _wait(self, key: str, now: float) -> float:
        record = self._records.get(key)
        if record is None:
            return 0.0
        over = record.failures - self._limit(key)
        if over < 0:
            if now - record.last > self.lockout_seconds:  # a quiet spell forgives them
                del self._records[key]
            return 0.0
        lockout = min(self.lockout_seconds * 2.0**over, MAX_LOCKOUT_SECONDS)
        wait = record.last + lockout - now
        if wait <= 0 and now - record.last > MAX_LOCKOUT_SECONDS:
            del self._records[key]
        return max(0.0, wait)

    def retry_after(self, *keys: str) -> float:
        """Seconds until these keys may try again (0 when not locked out)."""
        now = self.clock()
        with self._lock:
            return max((self._wait(key, now) for key in keys), default=0.0)

    def record_failure(self, *keys: str) -> None:
        now = self.clock()
        with self._lock:
            for key in keys:
                record = self._records.setdefault(key, _Record())
                record.failures += 1
                record.last = now
            if now >= self._next_sweep or len(self._records) > self.max_records:
                self._prune(now)

    def _prune(self, now: float) -> None:
        """Drop records with no effect left; then, above the cap, the oldest."""
        forgotten_after = max(self.lockout_seconds, MAX_LOCKOUT_SECONDS)
        for key in [k for k, r in self._records.items() if now - r.last > forgotten_after]:
            del self._records[key]
        if len(self._records) > self.max_records:
            # Down to 90 %: the sort then runs once per tenth of the cap, not per failure.
            excess = len(self._records) - self.max_records * 9 // 10
            oldest = sorted(self._records, key=lambda k: self._records[k].last)[:excess]
            for key in oldest:
                del self._records[key]
        self._next_sweep = now + SWEEP_SECONDS

    def reset(self, *keys: str) -> None:
        with self._lock:
            for key in keys:
                self._records.pop(key, None)
