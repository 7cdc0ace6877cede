"""`chameleons worker`: options over settings over defaults."""

from __future__ import annotations

from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from chameleons.cli.worker_command import build_config, worker
from chameleons.settings import Settings
from chameleons.worker.curve import create_keys


def test_defaults_copy_4_000_seconds_at_125_and_25_hz() -> None:
    config = build_config(Settings(), behaviour="copy")
    assert config.initial_params() == {"delay": 4.0}
    assert (config.render.tick_rate, config.render.face_rate) == (125.0, 25.0)
    assert config.driver == "virtual"
    assert config.command_endpoint == "tcp://127.0.0.1:5555"


def test_options_win_over_settings(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("CHAMELEONS_WORKER_COPY_DELAY", "2.5")
    monkeypatch.setenv("CHAMELEONS_WORKER_DRIVER", "furhat")
    monkeypatch.setenv("CHAMELEONS_DATA_DIR", str(tmp_path / "data"))  # no keys there
    settings = Settings()
    from_settings = build_config(settings, behaviour="copy")
    assert from_settings.copy_delay == 2.5
    assert from_settings.driver == "furhat"
    # A server on the network: allowed with CURVE keys only (none: refused, clearly).
    with pytest.raises(click.ClickException, match="chameleons keys create"):
        build_config(settings, behaviour="copy", control="tcp://10.0.0.2:5555")
    create_keys(tmp_path / "keys")
    config = build_config(settings, behaviour="copy", copy_delay=1.0, driver="null",
                          booth="b7", control="tcp://10.0.0.2:5555",
                          keys_dir=tmp_path / "keys")  # fmt: skip
    assert (config.copy_delay, config.driver, config.booth) == (1.0, "null", "b7")
    assert config.command_endpoint == "tcp://10.0.0.2:5555"
    assert config.curve is not None


def test_a_negative_delay_is_refused() -> None:
    with pytest.raises(click.BadParameter):
        build_config(Settings(), behaviour="copy", copy_delay=-1.0)


def test_help_lists_the_documented_options() -> None:
    result = CliRunner().invoke(worker, ["--help"])
    assert result.exit_code == 0
    for option in ("--booth", "--driver", "--robot-url", "--livelink-port",
                   "--facecapturex-port", "--behaviour", "--copy-delay", "--control",
                   "--furhat-face"):  # fmt: skip
        assert option in result.output


def test_furhat_faces_from_settings_and_options_options_win(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("CHAMELEONS_WORKER_FURHAT_FACES", '{"face-1": "Isabel", "face-2": "Marty"}')
    settings = Settings()
    assert build_config(settings, behaviour="still").furhat_faces == {
        "face-1": "Isabel", "face-2": "Marty",
    }  # fmt: skip
    config = build_config(settings, behaviour="still",
                          furhat_faces=("face-2=Titan", " face-3 = Fedora "))  # fmt: skip
    assert config.furhat_faces == {"face-1": "Isabel", "face-2": "Titan", "face-3": "Fedora"}


def test_a_furhat_face_without_a_robot_face_is_refused() -> None:
    with pytest.raises(click.BadParameter, match="STUDY_FACE=ROBOT_FACE"):
        build_config(Settings(), behaviour="still", furhat_faces=("face-1",))
    result = CliRunner().invoke(worker, ["--furhat-face", "face-1=", "--driver", "null"])
    assert result.exit_code != 0
    assert "--furhat-face" in result.output
