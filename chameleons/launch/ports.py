"""Ports for a local system (`chameleons demo`): the configured ones when they are free,
otherwise free ones chosen here, so a second demo on the same machine just starts.

The web port is bound here and the socket handed to uvicorn, so "port in use" is found
before anything is printed. The other ports are only probed: the worker and the server bind
them a moment later (the server's worker link during its start-up, still before the
welcome: :mod:`chameleons.cli.startup`). An address this computer cannot listen on at all
is a :class:`PortError` naming the setting.
"""

from __future__ import annotations

import errno
import socket
from dataclasses import dataclass, field

from chameleons.settings import Settings

DEFAULT_WEB_PORT = 8000
NEXT_WEB_PORTS = 10  # try 8001..8010 before any free port, so the URL stays memorable


class PortError(Exception):
    """A port the user asked for cannot be used (one sentence, for the CLI)."""


@dataclass
class ChosenPorts:
    settings: Settings
    web: socket.socket
    # "what: configured -> chosen" for each port that had to move, to print.
    moved: list[str] = field(default_factory=list)


def choose_ports(settings: Settings, *, web_port_given: bool) -> ChosenPorts:
    """Bind the web port and pick free worker and capture ports where the configured ones
    are taken (or 0, "any free port")."""
    web, moved = _bind_web(settings, web_port_given)
    try:
        update, more = _other_ports(settings)
    except BaseException:
        web.close()
        raise
    update["port"] = web.getsockname()[1]
    return ChosenPorts(settings.model_copy(update=update), web, moved + more)


def _other_ports(settings: Settings) -> tuple[dict[str, object], list[str]]:
    update: dict[str, object] = {}
    moved: list[str] = []
    for name, label in (("worker_command_endpoint", "worker control (ZeroMQ)"),
                        ("worker_telemetry_endpoint", "worker telemetry (ZeroMQ)")):  # fmt: skip
        endpoint: str = getattr(settings, name)
        chosen = _free_endpoint(endpoint, _variable(name))
        if chosen != endpoint:
            update[name] = chosen
            moved.append(f"{label}: {endpoint} in use, using {chosen}")
    host = settings.capture_bind_host
    # Live Link Face streams over UDP; FaceCaptureX connects over TCP.
    for name, label, kind in (
        ("livelink_port", "Live Link Face (UDP)", socket.SOCK_DGRAM),
        ("facecapturex_port", "FaceCaptureX (TCP)", socket.SOCK_STREAM),
    ):
        port: int = getattr(settings, name)
        where = f"{_variable(name)} with CHAMELEONS_CAPTURE_BIND_HOST={host}"
        if port == 0 or _taken(host, port, kind, where):
            chosen_port = _any_port(host, kind, where)
            update[name] = chosen_port
            if port:
                moved.append(f"{label}: port {port} in use, using {chosen_port}")
    return update, moved


def _variable(name: str) -> str:
    return f"CHAMELEONS_{name.upper()}"


def _taken(host: str, port: int, kind: socket.SocketKind, where: str) -> bool:
    """Whether ``port`` is in use; any other reason it cannot be bound is a PortError."""
    try:
        if kind == socket.SOCK_STREAM:
            _listen(host, port).close()
        else:
            with socket.socket(_family(host), socket.SOCK_DGRAM) as probe:
                probe.bind((host, port))
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            return True
        raise PortError(
            f"Cannot listen on {host}:{port} ({where}): {exc.strerror or exc}."
        ) from exc
    return False


def _any_port(host: str, kind: socket.SocketKind, where: str) -> int:
    try:
        return free_port(host, kind)
    except OSError as exc:
        raise PortError(f"Cannot listen on {host} ({where}): {exc.strerror or exc}.") from exc


def _bind_web(settings: Settings, given: bool) -> tuple[socket.socket, list[str]]:
    host, port = settings.host, settings.port
    try:
        return _listen(host, port), []
    except OSError as exc:
        if given or port != DEFAULT_WEB_PORT or exc.errno != errno.EADDRINUSE:
            raise PortError(_web_error(host, port, exc)) from exc
    for candidate in [*range(port + 1, port + 1 + NEXT_WEB_PORTS), 0]:
        try:
            web = _listen(host, candidate)
        except OSError:
            continue
        return web, [f"web: port {port} in use, using {web.getsockname()[1]}"]
    raise PortError(f"No free port to serve the web pages on {host}.")  # pragma: no cover


def _web_error(host: str, port: int, exc: OSError) -> str:
    if exc.errno == errno.EADDRINUSE:
        return (f"Port {port} on {host} is in use (another chameleons demo or server?): "
                "choose another with --port.")  # fmt: skip
    if exc.errno == errno.EACCES:
        return f"Port {port} on {host} needs administrator rights: choose one above 1023."
    return f"Cannot serve on {host}:{port}: {exc.strerror or exc}."


def _listen(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        # As uvicorn sets it: a restarted demo is not refused for connections in TIME_WAIT.
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.listen(2048)
    except OSError:
        sock.close()
        raise
    sock.set_inheritable(True)
    return sock


def _free_endpoint(endpoint: str, variable: str) -> str:
    """A ``tcp://HOST:PORT`` endpoint, or the same host on a free port when it is taken."""
    scheme, _, address = endpoint.partition("://")
    host, _, port = address.rpartition(":")
    if scheme != "tcp" or not port.isdigit():
        return endpoint  # ipc://, inproc:// or tcp://host:* (ZeroMQ picks) need no choice
    host = host.strip("[]")
    if not _taken(host, int(port), socket.SOCK_STREAM, variable):
        return endpoint
    chosen = _any_port(host, socket.SOCK_STREAM, variable)
    return f"tcp://[{host}]:{chosen}" if ":" in host else f"tcp://{host}:{chosen}"


def free_port(host: str, kind: socket.SocketKind) -> int:
    """A port the system calls free now (another process may still take it first)."""
    with socket.socket(_family(host), kind) as probe:
        probe.bind((host, 0))
        return int(probe.getsockname()[1])


def _family(host: str) -> socket.AddressFamily:
    return socket.AF_INET6 if ":" in host else socket.AF_INET
