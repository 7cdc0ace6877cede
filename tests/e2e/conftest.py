"""Browser tests exercise the pages; one backend (SQLite) is enough for them. (Both
databases are exercised by the API and reliability tests of the same behaviour.)"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest


@pytest.fixture
def database_url(sqlite_template: Path, tmp_path: Path) -> str:
    path = tmp_path / "browser.sqlite3"
    shutil.copyfile(sqlite_template, path)
    return f"sqlite:///{path}"
