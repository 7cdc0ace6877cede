"""The commands' one owner of SIGINT and SIGTERM (chameleons.launch.interrupts), with real
signals to this process and a real uvicorn server in this thread, in each order the signal
can meet the server: before it starts, while its application starts, once it serves. And a
signal whose exception Python loses in a finalizer still ends the command with 130."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import AsyncIterator, Callable, Iterator
from contextlib import asynccontextmanager
from typing import Any

import pytest
from fastapi import FastAPI

from chameleons.launch.interrupts import Interrupted, Interrupts, interrupts
from chameleons.launch.web_server import WebServer, run_until_stopped, web_config
from chameleons.settings import Settings

pytestmark = pytest.mark.skipif(
    threading.current_thread() is not threading.main_thread(),
    reason="signal handlers can be installed in the main thread only",
)


@pytest.fixture(autouse=True)
def _handlers_restored() -> Iterator[None]:
    """Each test leaves this process's handlers as it found them (pytest's own)."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    yield
    assert {s: signal.getsignal(s) for s in before} == before


def _app(log: list[str], signal_in_startup: int | None = None) -> FastAPI:
    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        log.append("startup")
        if signal_in_startup is not None:
            os.kill(os.getpid(), signal_in_startup)  # while the application starts
        yield
        log.append("shutdown")

    return FastAPI(lifespan=lifespan)


def _server(app: FastAPI) -> WebServer:
    config = web_config(app, Settings(_env_file=None), host="127.0.0.1", port=0,
                        log_level="warning")  # fmt: skip
    return WebServer(config)


def _signal_once_serving(server: WebServer, signum: int) -> threading.Thread:
    """A thread that sends ``signum`` to this process once ``server`` serves."""

    def send() -> None:
        while not server.started:  # polls the server's own flag: the event to act on
            threading.Event().wait(0.005)
        os.kill(os.getpid(), signum)

    thread = threading.Thread(target=send, daemon=True)
    thread.start()
    return thread


def _command(body: Callable[[Interrupts], None]) -> None:
    """``body`` as a command runs it: under the command's own handlers."""
    with interrupts() as stops:
        body(stops)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_while_the_server_serves_stops_it_gracefully_then_exits_128_plus(
    signum: int,
) -> None:
    log: list[str] = []
    server = _server(_app(log))
    sender = _signal_once_serving(server, signum)
    with pytest.raises(SystemExit) as left:
        _command(lambda stops: run_until_stopped(server, stops))
    sender.join()
    assert left.value.code == 128 + signum
    assert log == ["startup", "shutdown"]  # uvicorn shut down in order, lifespan and all


def test_a_signal_while_the_application_starts_never_serves_and_still_shuts_down() -> None:
    log: list[str] = []
    server = _server(_app(log, signal_in_startup=signal.SIGINT))
    with pytest.raises(SystemExit) as left:
        _command(lambda stops: run_until_stopped(server, stops))
    assert left.value.code == 130
    assert log == ["startup", "shutdown"]


def test_a_signal_before_the_server_starts_leaves_without_starting_it() -> None:
    log: list[str] = []
    server = _server(_app(log))

    def start_up_then_serve(stops: Interrupts) -> None:
        with contextlib.suppress(Interrupted):  # as if lost on its way (see below)
            signal.raise_signal(signal.SIGINT)  # e.g. during the migrations
        run_until_stopped(server, stops)

    with pytest.raises(SystemExit) as left:
        _command(start_up_then_serve)
    assert left.value.code == 130
    assert log == []
    assert not server.started


class _Finalized:
    """Raises the signal while Python finalizes it, where exceptions are only reported."""

    def __del__(self) -> None:
        signal.raise_signal(signal.SIGINT)


def test_a_signal_whose_exception_is_lost_in_a_finalizer_still_ends_with_130(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    lost: list[BaseException | None] = []
    monkeypatch.setattr(sys, "unraisablehook", lambda raised: lost.append(raised.exc_value))
    stopped: list[bool] = []
    carried_on: list[Interrupts] = []

    def work(stops: Interrupts) -> None:
        with stops.stopping(stopped.append):
            _Finalized()  # collected at once: its __del__ raises the signal
            carried_on.append(stops)  # the exception did not get here: Python dropped it

    with pytest.raises(SystemExit) as left:
        _command(work)
    assert carried_on
    assert [type(e) for e in lost] == [Interrupted]
    assert stopped == [False]  # what the command runs was told to stop all the same
    assert left.value.code == 130
    with pytest.raises(Interrupted):
        carried_on[0].check()  # and the command's next step leaves


def test_a_second_signal_forces_the_stop_but_does_not_cut_the_clean_up_short() -> None:
    told: list[bool] = []
    cleaned: list[Interrupts] = []

    def work(stops: Interrupts) -> None:
        with stops.stopping(told.append):
            try:
                signal.raise_signal(signal.SIGTERM)
            except Interrupted:
                signal.raise_signal(signal.SIGINT)  # during the clean-up: no exception
                cleaned.append(stops)

    with pytest.raises(SystemExit) as left:
        _command(work)
    assert cleaned
    assert told == [False, True]
    assert left.value.code == 143  # the first signal's status
    assert cleaned[0].received == 2


def test_without_a_signal_the_block_ends_as_it_would() -> None:
    with interrupts() as stops:
        stops.check()

    def fails(_stops: Interrupts) -> None:
        raise ValueError("its own error")

    with pytest.raises(ValueError, match="its own"):
        _command(fails)


def test_quiet_blocks_get_no_exception_and_check_tells_afterwards() -> None:
    stops = Interrupts()
    flags: dict[str, Any] = {}
    with stops.stopping(lambda again: flags.setdefault("again", again), quiet=True):
        stops.handle(signal.SIGINT, None)  # as the handler is called: nothing raised
    assert flags == {"again": False}
    with pytest.raises(Interrupted) as left:
        stops.check()
    assert left.value.code == 130
