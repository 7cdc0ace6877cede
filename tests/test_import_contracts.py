"""The import contracts of pyproject.toml (``[tool.importlinter]``) hold: the packages are
layered (commands > rehearsal > launching > server > domain > worker > face tracker >
shared vocabulary), a server feature's endpoints and pages sit above its service and its
repository, and no sibling packages or modules import each other in a circle. A new
circle or an arrow pointing up fails here, with import-linter's report of the import."""

from __future__ import annotations

from pathlib import Path

import pytest
from importlinter.cli import lint_imports

ROOT = Path(__file__).resolve().parents[1]


def test_the_import_contracts_are_kept(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(ROOT)  # the root package is found on the path, the contracts here
    status = lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True)
    report = capsys.readouterr().out
    assert status == 0, report
    assert "0 broken" in report, report
