"""The import contracts of pyproject.toml (``[tool.importlinter]``) hold: the packages are
layered (commands > rehearsal > launching > server > domain > worker > face tracker >
shared vocabulary), a server feature's endpoints and pages sit above its service and its
repository, and no sibling packages or modules import each other in a circle. A new
circle or an arrow pointing up fails here, with import-linter's report of the import."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# In its own process: import-linter's command configures logging with dictConfig, which
# disables every logger that already exists, so in the test process the later tests'
# caplog saw nothing from chameleons.worker.* (two tests failed that way in a full run).
LINT = (
    "import sys; from importlinter.cli import lint_imports; "
    "sys.exit(lint_imports(config_filename=sys.argv[1], no_cache=True))"
)


def test_the_import_contracts_are_kept() -> None:
    result = subprocess.run(
        [sys.executable, "-c", LINT, str(ROOT / "pyproject.toml")],
        cwd=ROOT, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    report = result.stdout + result.stderr
    assert result.returncode == 0, report
    assert "0 broken" in report, report
