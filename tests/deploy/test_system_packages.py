"""The one list of system packages the tests need (scripts/system-packages.txt), used by
`make test` (scripts/system_packages.sh ensure) and by .ci/run (install --all): it parses,
both callers use it, and `ensure` stops before anything runs, naming the one command, when
it cannot install what is missing."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "system_packages.sh"
LIST = ROOT / "scripts" / "system-packages.txt"


def _entries() -> list[list[str]]:
    lines = LIST.read_text("utf-8").splitlines()
    return [line.split(None, 2) for line in lines if line.strip() and not line.startswith("#")]


def test_the_list_names_each_package_with_a_check() -> None:
    entries = _entries()
    assert all(len(entry) == 3 and entry[1] in ("all", "pg") for entry in entries), entries
    names = {entry[0] for entry in entries}
    assert {"chromium", "espeak-ng", "fonts-noto-core", "fonts-noto-cjk", "r-cran-lme4",
            "r-cran-ordinal", "postgresql"} <= names  # fmt: skip


def test_missing_prints_only_listed_packages() -> None:
    result = subprocess.run(
        [str(SCRIPT), "missing", "--all"], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
    names = {entry[0] for entry in _entries()}
    assert set(result.stdout.split()) <= names


def test_make_test_and_ci_use_the_list() -> None:
    makefile = (ROOT / "Makefile").read_text("utf-8")
    recipe = makefile.split("\ntest:\n", 1)[1].splitlines()
    assert recipe[0].strip() == "scripts/system_packages.sh ensure"
    ci = (ROOT / ".ci" / "run").read_text("utf-8")
    assert "scripts/system_packages.sh install --all" in ci
    assert ci.rstrip().splitlines()[-1] == "make test"


def _copy_with_list(tmp_path: Path, lines: str) -> Path:
    folder = tmp_path / "scripts"
    folder.mkdir()
    shutil.copy2(SCRIPT, folder / SCRIPT.name)
    (folder / LIST.name).write_text(lines, "utf-8")
    tmp_path.chmod(0o755)
    return folder / SCRIPT.name


def test_ensure_without_apt_names_the_packages_and_stops(tmp_path: Path) -> None:
    script = _copy_with_list(tmp_path, "no-such-package-x  all  false\n")
    tools = tmp_path / "bin"
    tools.mkdir()
    for tool in ("bash", "dirname", "id", "sed"):
        found = shutil.which(tool)
        assert found is not None
        (tools / tool).symlink_to(found)
    result = subprocess.run(
        [str(tools / "bash"), str(script), "ensure"], capture_output=True, text=True,
        env={"PATH": str(tools)}, check=False,
    )  # fmt: skip
    assert result.returncode == 1
    assert "no-such-package-x" in result.stderr
    assert "package manager" in result.stderr


def test_ensure_that_cannot_install_names_the_one_command() -> None:
    if shutil.which("apt-get") is None:
        pytest.skip("the install path is for Debian/Ubuntu (apt-get)")
    # A folder the other user can read (pytest's tmp_path is private to this user).
    with tempfile.TemporaryDirectory() as folder:
        script = _copy_with_list(Path(folder), "no-such-package-x  all  false\n")
        result = _ensure_as_a_user_who_cannot_install(script)
    assert result.returncode == 1, result.stderr
    assert "no-such-package-x" in result.stderr
    assert "sudo scripts/system_packages.sh install" in result.stderr


def _ensure_as_a_user_who_cannot_install(script: Path) -> subprocess.CompletedProcess[str]:
    command = [str(script), "ensure"]
    if os.geteuid() == 0:  # run it as a user without sudo: nobody
        setpriv = shutil.which("setpriv")
        if setpriv is None:
            pytest.skip("setpriv is needed to run the script as another user")
        command = [setpriv, "--reuid=65534", "--regid=65534", "--clear-groups", *command]
    elif subprocess.run(["sudo", "-n", "true"], capture_output=True, check=False).returncode == 0:
        pytest.skip("this user may sudo without a password, so ensure would install")
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin")}
    return subprocess.run(command, capture_output=True, text=True, env=env, check=False)


def test_postgresql_counts_only_for_its_half(tmp_path: Path) -> None:
    script = _copy_with_list(tmp_path, "pg-only-package  pg  false\n")
    env = {k: v for k, v in os.environ.items() if k != "TEST_DATABASE_URL"}
    without = subprocess.run([str(script), "missing"], capture_output=True, text=True, env=env,
                             check=True)  # fmt: skip
    assert without.stdout.split() == []
    env["TEST_DATABASE_URL"] = "postgresql://postgres@127.0.0.1:5432/test"
    with_url = subprocess.run([str(script), "missing"], capture_output=True, text=True, env=env,
                              check=True)  # fmt: skip
    assert with_url.stdout.split() == ["pg-only-package"]
