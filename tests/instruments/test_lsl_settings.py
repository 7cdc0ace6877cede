"""LSL is off unless asked for: ``CHAMELEONS_LSL`` turns it on for the server and the
workers; ``chameleons worker --lsl``/``--no-lsl`` wins over the setting."""

from __future__ import annotations

from pathlib import Path

import pytest

from chameleons.cli.worker_command import build_config
from chameleons.instruments.lsl import marker_text, parse_marker, require_pylsl, stream_name
from chameleons.settings import Settings


def test_off_by_default_on_by_setting_and_the_option_wins(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("CHAMELEONS_DATA_DIR", str(tmp_path))
    assert Settings(_env_file=None).lsl is False
    assert build_config(Settings(_env_file=None), behaviour="still").lsl is False
    assert build_config(Settings(_env_file=None), behaviour="still", lsl=True).lsl is True
    monkeypatch.setenv("CHAMELEONS_LSL", "1")
    settings = Settings(_env_file=None)
    assert settings.lsl is True
    assert build_config(settings, behaviour="still").lsl is True
    assert build_config(settings, behaviour="still", lsl=False).lsl is False


def test_markers_name_their_event_and_keep_free_text_off_the_network() -> None:
    event = {"id": 7, "kind": "wizard.note", "session_id": 3, "interaction_id": None,
             "source": "wizard", "server_time": "2026-03-02T09:00:00+00:00",
             "payload": {"text": "P cried", "position": 2, "typed": True,
                         "nested": [{"note": "private"}]}}  # fmt: skip
    marker = parse_marker(marker_text(event))
    assert marker is not None
    assert (marker["event_id"], marker["kind"], marker["session_id"]) == (7, "wizard.note", 3)
    assert marker["payload"] == {"text": "<text>", "position": 2, "typed": True,
                                 "nested": [{"note": "<text>"}]}  # fmt: skip
    assert parse_marker("stimulus_on") is None
    assert parse_marker('{"kind": "x"}') is None
    assert stream_name("booth-2", "events") == "chameleons-booth-2-events"
    with pytest.raises(ValueError, match="unknown LSL stream"):
        stream_name("booth-2", "video")


def test_a_missing_liblsl_is_said_in_one_sentence(monkeypatch: pytest.MonkeyPatch) -> None:
    import pylsl

    def missing() -> int:
        raise RuntimeError("LSL binary library file was not found.")

    monkeypatch.setattr(pylsl, "library_version", missing)
    with pytest.raises(
        RuntimeError,
        match=r"^LSL is on \(CHAMELEONS_LSL or --lsl\) but liblsl "
        r"cannot be loaded: reinstall the pylsl package",
    ):
        require_pylsl()
