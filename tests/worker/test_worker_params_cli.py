"""`chameleons worker --param NAME=VALUE`: the starting behaviour's parameters, read as YAML
and checked by the same code as a study condition's params."""

from __future__ import annotations

import click
import pytest
from click.testing import CliRunner

from chameleons.cli.worker_command import build_config, worker
from chameleons.settings import Settings


def test_params_reach_the_starting_behaviour() -> None:
    config = build_config(Settings(), behaviour="copy", params=(
        "channels=head", "gain={head: 0.5}", "delay={uniform: [0.5, 1.0]}", "mirror=false",
        "intermittent={rate_per_s: 0.2, bout_s: 3}", "seed=4"))  # fmt: skip
    assert config.initial_params() == {
        "delay": {"uniform": [0.5, 1.0]}, "channels": "head", "gain": {"head": 0.5},
        "mirror": False, "intermittent": {"rate_per_s": 0.2, "bout_s": 3}, "seed": 4,
    }  # fmt: skip


def test_coexpress_needs_no_delay_and_copy_delay_still_works() -> None:
    config = build_config(Settings(), behaviour="copy", params=("coexpress=true",))
    assert config.initial_params() == {"coexpress": True}
    config = build_config(Settings(), behaviour="copy", copy_delay=0.7, params=("gain=2",))
    assert config.initial_params() == {"delay": 0.7, "gain": 2}


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ("channels=nose", "channels: 'nose' is not a channel"),
        ("gain=9", "gain: must be a number in 0..3"),
        ("speed=2", "speed: unknown parameter"),
        ("delay={uniform: [2, 1]}", "delay: uniform must be [low, high]"),
        ("gain", "'gain' is not NAME=VALUE"),
        ("gain=[1", "the value of gain is not valid YAML"),
    ],
)
def test_bad_params_are_refused_before_the_worker_starts(entry: str, message: str) -> None:
    with pytest.raises(click.BadParameter, match=message.replace("[", r"\[")):
        build_config(Settings(), behaviour="copy", params=(entry,))


def test_the_command_line_says_what_is_wrong() -> None:
    result = CliRunner().invoke(worker, ["--behaviour", "copy", "--param", "only=[winks]"])
    assert result.exit_code == 2
    assert "'winks' is not a named expression" in result.output
    assert "--param" in CliRunner().invoke(worker, ["--help"]).output
