"""A real uvicorn server on a loopback port, in a background thread.

``port=0`` picks a free port; a given port lets a test stop a server and start a new app on
the same address (a server restart as a phone or a display page sees it). ``send_buffer``
fixes the kernel's send buffer of every connection (a client that stops reading then
makes the server's writes wait after kilobytes, not megabytes).
"""

from __future__ import annotations

import socket
import threading
import time
from typing import Literal

import uvicorn
from fastapi import FastAPI


class LiveServer:
    def __init__(
        self,
        app: FastAPI,
        port: int = 0,
        lifespan: Literal["on", "off"] = "on",
        send_buffer: int | None = None,
    ) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if send_buffer is not None:
            # Accepted connections inherit it (and lose the kernel's autotuning, which grows
            # a stalled client's backlog to megabytes before the server's writes wait).
            self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, send_buffer)
        self._sock.bind(("127.0.0.1", port))
        self.port: int = self._sock.getsockname()[1]
        config = uvicorn.Config(
            app,
            log_level="warning",
            lifespan=lifespan,
            ws="websockets-sansio",
            timeout_graceful_shutdown=2,
        )
        self._server = uvicorn.Server(config)
        self._thread = threading.Thread(
            target=self._server.run, kwargs={"sockets": [self._sock]}, daemon=True
        )

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def start(self, timeout: float = 10.0) -> LiveServer:
        self._thread.start()
        deadline = time.monotonic() + timeout
        while not self._server.started:  # polls readiness; not a fixed wait
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError("live server did not start")
            time.sleep(0.005)
        return self

    def stop(self) -> None:
        self._server.should_exit = True
        self._thread.join(timeout=10)
        self._sock.close()

    def __enter__(self) -> LiveServer:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()
