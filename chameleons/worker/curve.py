"""CURVE keys for the ZeroMQ link between the server and its workers (authenticated and
encrypted; pyzmq's ``zmq.auth``).

``chameleons keys create`` writes, in the keys directory (``<data dir>/keys`` unless
``CHAMELEONS_ZMQ_KEYS_DIR``)::

    server.key, server.key_secret      the server's key pair (the bridge binds with it)
    worker.key, worker.key_secret      a worker key pair (``--worker NAME`` for more)
    authorized/worker.key              public keys of the workers the server accepts

A booth PC gets ``server.key`` (public) and its own ``<name>.key`` + ``<name>.key_secret``.
The server accepts only clients whose public key is in ``authorized/``; anything else on
the network cannot connect, send a hello, a telemetry line or an event.

Without keys the link runs unauthenticated, which the server and worker allow only while
every endpoint is on the loopback interface (:func:`require_safe`). ``chameleons demo``
creates the keys itself.
"""

from __future__ import annotations

import ipaddress
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import zmq
import zmq.auth

SERVER, WORKER, AUTHORIZED = "server", "worker", "authorized"
PUBLIC, SECRET = ".key", ".key_secret"


class CurveError(RuntimeError):
    """Keys missing, unreadable, or an unauthenticated link that would leave this host."""


@dataclass(frozen=True)
class ServerKeys:
    public: bytes
    secret: bytes
    authorized: Path  # folder of accepted worker public keys


@dataclass(frozen=True)
class ClientKeys:
    public: bytes
    secret: bytes
    server_public: bytes


def create_keys(directory: Path, worker: str = WORKER, *, force: bool = False) -> list[Path]:
    """Create the server's key pair (unless present) and ``worker``'s, and authorize the
    worker's public key. Refuses to overwrite a key pair unless ``force``."""
    if not zmq.has("curve"):
        raise CurveError("this libzmq has no CURVE support (install pyzmq's wheel)")
    directory.mkdir(parents=True, exist_ok=True)
    directory.chmod(0o700)  # secret keys inside
    authorized = directory / AUTHORIZED
    authorized.mkdir(exist_ok=True)
    made: list[Path] = []
    if force or not (directory / f"{SERVER}{SECRET}").exists():
        made += _pair(directory, SERVER)
    if (directory / f"{worker}{SECRET}").exists() and not force:
        raise CurveError(f"a key pair for {worker!r} exists in {directory} (--force replaces it)")
    made += _pair(directory, worker)
    shutil.copyfile(directory / f"{worker}{PUBLIC}", authorized / f"{worker}{PUBLIC}")
    return made


def _pair(directory: Path, name: str) -> list[Path]:
    public, secret = zmq.auth.create_certificates(str(directory), name)
    Path(secret).chmod(0o600)
    return [Path(public), Path(secret)]


def have_server_keys(directory: Path) -> bool:
    return (directory / f"{SERVER}{SECRET}").is_file()


def load_server(directory: Path) -> ServerKeys:
    public, secret = _load(directory / f"{SERVER}{SECRET}")
    authorized = directory / AUTHORIZED
    if not authorized.is_dir() or not any(authorized.glob(f"*{PUBLIC}")):
        raise CurveError(f"no worker is authorized: {authorized} holds no public key "
                         "(run `chameleons keys create`)")  # fmt: skip
    return ServerKeys(public, secret, authorized)


def load_client(directory: Path, worker: str = WORKER) -> ClientKeys:
    public, secret = _load(directory / f"{worker}{SECRET}")
    server_public, _ = _load(directory / f"{SERVER}{PUBLIC}", secret_needed=False)
    return ClientKeys(public, secret, server_public)


def have_client_keys(directory: Path, worker: str = WORKER) -> bool:
    pair = directory / f"{worker}{SECRET}"
    return pair.is_file() and (directory / f"{SERVER}{PUBLIC}").is_file()


def _load(path: Path, *, secret_needed: bool = True) -> tuple[bytes, bytes]:
    try:
        public, secret = zmq.auth.load_certificate(str(path))
    except (OSError, ValueError) as exc:
        raise CurveError(f"cannot read the CURVE key {path}: {exc}") from exc
    if secret_needed and not secret:
        raise CurveError(f"{path} holds no secret key")
    return public, secret or b""


def apply_server(socket: zmq.Socket[Any], keys: ServerKeys) -> None:
    socket.curve_secretkey = keys.secret
    socket.curve_publickey = keys.public
    socket.curve_server = True


def apply_client(socket: zmq.Socket[Any], keys: ClientKeys) -> None:
    socket.curve_secretkey = keys.secret
    socket.curve_publickey = keys.public
    socket.curve_serverkey = keys.server_public


def is_loopback(endpoint: str) -> bool:
    """Whether a ZeroMQ endpoint stays on this host (inproc, ipc, tcp to loopback)."""
    parts = urlsplit(endpoint)
    if parts.scheme in ("inproc", "ipc"):
        return True
    host = (parts.hostname or "").strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # "*", an interface name or a host name: reachable from outside


def require_safe(endpoints: list[str], *, who: str) -> str:
    """Without keys: a sentence saying the link is unauthenticated on loopback only, or a
    :class:`CurveError` when an endpoint leaves this host."""
    outside = [e for e in endpoints if not is_loopback(e)]
    if outside:
        raise CurveError(
            f"the {who}'s ZeroMQ endpoint {outside[0]} is reachable from the network, but no "
            "CURVE keys are configured: anyone there could drive the robot or inject "
            "recordings. Run `chameleons keys create` (see docs/hardware/booth-pc.md) or "
            "bind to 127.0.0.1."
        )
    return (f"the {who}'s ZeroMQ link runs unauthenticated, on loopback only "
            "(`chameleons keys create` turns on CURVE)")  # fmt: skip
