"""The server looks for espeak-ng as it starts (issue 28: the wizard used to learn that
typed speech cannot speak only from a refused sentence in the middle of a session): the
finding is on ``app.state``, in the log when espeak-ng is missing, and on the console's
health strip (test_health.py; the browser test shows the chip)."""

from __future__ import annotations

import logging
import os
import shutil
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.wizard import typed_speech


def without_espeak(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """A PATH with every program of the real one but espeak-ng (links, not copies)."""
    folder = tmp_path / "bin"
    folder.mkdir()
    for directory in os.environ.get("PATH", "").split(os.pathsep):
        if not os.path.isdir(directory):
            continue
        for name in os.listdir(directory):
            target = folder / name
            if name != "espeak-ng" and not target.exists():
                target.symlink_to(Path(directory) / name)
    monkeypatch.setenv("PATH", str(folder))
    assert shutil.which("espeak-ng") is None


@pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed")
def test_a_working_espeak_is_found_with_its_version() -> None:
    found = typed_speech.check_synthesiser()
    assert found.available is True
    assert found.detail.startswith("espeak-ng ")
    assert any(ch.isdigit() for ch in found.detail)


def test_a_missing_espeak_is_said_with_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    without_espeak(monkeypatch, tmp_path)
    found = typed_speech.check_synthesiser()
    assert found.available is False
    assert found.detail.startswith("espeak-ng not installed")
    assert "apt install espeak-ng" in found.detail


def test_an_espeak_that_does_not_run_is_not_taken_for_a_working_one(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    folder = tmp_path / "broken"
    folder.mkdir()
    program = folder / "espeak-ng"
    program.write_text("#!/bin/sh\necho 'espeak-ng: cannot load voice data' >&2\nexit 1\n")
    program.chmod(0o755)
    monkeypatch.setenv("PATH", f"{folder}{os.pathsep}{os.environ.get('PATH', '')}")
    found = typed_speech.check_synthesiser()
    assert found.available is False
    assert found.detail == "espeak-ng does not run: espeak-ng: cannot load voice data"


def test_the_server_checks_at_start_up_and_logs_a_missing_one(
    app: FastAPI,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
) -> None:
    without_espeak(monkeypatch, tmp_path)
    assert typed_speech.synthesiser_of(app.state) is None  # not before the start-up
    with caplog.at_level(logging.WARNING), TestClient(app):
        found = typed_speech.synthesiser_of(app.state)
        assert found is not None
        assert found.available is False
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("Typed speech (the console's Say field) cannot speak: espeak-ng not installed"
               in message for message in warnings), warnings  # fmt: skip
