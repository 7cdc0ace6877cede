"""Which phone the capture listens to: a worker accepts Live Link Face and FaceCaptureX input
from one sender only.

Live Link Face streams UDP to a port any device on the network can reach; without a lock,
any sender there turns the robot's head. The lock is by IP address (the app's source port
changes when it restarts, the phone's address does not):

- **configured** (``CHAMELEONS_CAPTURE_SENDER``, ``chameleons worker --capture-sender``):
  only that address, always;
- otherwise **first sender**: the first sender after a reset is the paired phone. The
  server resets the pairing when a session starts on the booth and when the wizard asks
  (``reset_pairing`` command), so the next participant's phone pairs afresh.

Packets (Live Link) and connections (FaceCaptureX) from anyone else are dropped and counted;
telemetry carries the paired sender and the count, the wizard's *Face stream* chip shows
both.
"""

from __future__ import annotations

import ipaddress
import socket
import threading
from typing import Any

FIRST, CONFIGURED = "first_sender", "configured"


def normalise(address: str) -> str:
    """An IP address as text, IPv4-mapped IPv6 (``::ffff:10.0.0.5``) as plain IPv4."""
    try:
        ip = ipaddress.ip_address(address.split("%", 1)[0])
    except ValueError:
        return address
    mapped = getattr(ip, "ipv4_mapped", None)
    return str(mapped or ip)


def resolve(configured: str) -> str:
    """A configured sender: an IP address, or a host name resolved once at start."""
    text = configured.strip()
    try:
        return normalise(str(ipaddress.ip_address(text)))
    except ValueError:
        pass
    try:
        return normalise(socket.gethostbyname(text))
    except OSError as exc:
        raise ValueError(f"capture sender {text!r} is neither an IP address nor a known "
                         f"host name ({exc})") from exc  # fmt: skip


class SenderLock:
    """Thread-safe: receivers call :meth:`admit`, the hub :meth:`reset` and :meth:`snapshot`."""

    def __init__(self, configured: str | None = None) -> None:
        self.configured = resolve(configured) if configured else None
        self._lock = threading.Lock()
        self._paired: str | None = self.configured
        self._others = 0
        self._last_other: str | None = None
        self._pairings = 0

    def admit(self, address: str) -> bool:
        """Whether input from ``address`` is accepted (pairing with it when none is)."""
        sender = normalise(address)
        with self._lock:
            if self._paired is None:
                self._paired, self._pairings = sender, self._pairings + 1
            if sender == self._paired:
                return True
            self._others += 1
            self._last_other = sender
            return False

    def reset(self) -> dict[str, Any]:
        """Forget the paired phone (a configured sender stays) and the counts."""
        with self._lock:
            previous = self._paired
            self._paired = self.configured
            self._others, self._last_other = 0, None
        return {"previous": previous, **self.snapshot()}

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            return {
                "mode": CONFIGURED if self.configured else FIRST,
                "sender": self._paired,  # None: waiting for the first phone
                "other_packets": self._others,
                "last_other": self._last_other,
                "pairings": self._pairings,
            }
