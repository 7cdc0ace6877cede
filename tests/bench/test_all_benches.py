"""``python -m bench.all`` runs every server-side benchmark: each command it would run is
one its benchmark accepts, in quick mode too."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

from bench import all as every

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("quick", [False, True])
def test_every_command_is_one_its_benchmark_accepts(quick: bool, tmp_path: Path) -> None:
    planned = every.commands(quick, tmp_path, worker=False)
    assert set(planned) == {
        "server",
        "calls",
        "console",
        "check",
        "speech",
        "data",
        "cli",
        "display",
        "synchrony",
    }
    for command in planned.values():
        assert command[:2] == [sys.executable, "-m"]
        module = importlib.import_module(command[2])
        args = module.parser().parse_args(command[3:])
        assert args.quick is quick
        assert args.json.parent == tmp_path


def test_the_list_names_the_commands_without_running_them() -> None:
    command = [sys.executable, "-m", "bench.all", "--list", "--quick", "--worker"]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120,
                          check=True)  # fmt: skip
    names = ("server_bench", "submission_calls", "console_dom_bench", "independent_check",
             "speech_bench",
             "data_bench", "cli_bench",
             "display_bench", "synchrony_bench", "worker_bench", "webcam_bench")  # fmt: skip
    assert done.stdout.splitlines() == [f"-m bench.{name} --quick" for name in names]
