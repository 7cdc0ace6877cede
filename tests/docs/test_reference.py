"""The reference pages (docs/reference/) are generated from the code by
scripts/docs_reference.py; these tests fail while a committed page is stale, naming the
command that regenerates it, and check that the pages cover every command, option and
setting."""

from __future__ import annotations

import difflib
import importlib.util
from pathlib import Path
from types import ModuleType

import click
import pytest
from click.testing import CliRunner

from chameleons.cli.main import COMMANDS, cli
from chameleons.settings import Settings

ROOT = Path(__file__).resolve().parents[2]


def _load_generator() -> ModuleType:
    path = ROOT / "scripts" / "docs_reference.py"
    spec = importlib.util.spec_from_file_location("docs_reference", path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def generator() -> ModuleType:
    return _load_generator()


@pytest.fixture(scope="module")
def pages(generator: ModuleType) -> dict[Path, str]:
    rendered: dict[Path, str] = generator.render()
    return rendered


def test_committed_reference_pages_match_the_code(
    generator: ModuleType, pages: dict[Path, str]
) -> None:
    stale = generator.stale(pages)
    names = ", ".join(str(path.relative_to(ROOT)) for path in stale)
    # The first lines that differ, so a difference that depends on what ran before in the
    # same process (state another test left behind) shows what it is.
    diff = "".join(
        line
        for path in stale
        for line in list(difflib.unified_diff(
            path.read_text("utf-8").splitlines(keepends=True) if path.exists() else [],
            pages[path].splitlines(keepends=True), str(path), "generated now", n=0,
        ))[:20]
    )  # fmt: skip
    assert not stale, (
        f"{names} differ from the code: run `make docs-reference` and commit them\n{diff}"
    )


def test_staleness_is_detected(generator: ModuleType, tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("old\n", "utf-8")
    assert generator.stale({page: "new\n"}) == [page]
    assert generator.stale({tmp_path / "missing.md": "new\n"}) == [tmp_path / "missing.md"]
    page.write_text("new\n", "utf-8")
    assert generator.stale({page: "new\n"}) == []


def _options(command: click.Command, ctx: click.Context) -> list[str]:
    return [
        opt
        for param in command.get_params(ctx)
        if isinstance(param, click.Option) and "--help" not in param.opts and not param.hidden
        for opt in param.opts
    ]


def test_cli_page_lists_every_command_and_option(pages: dict[Path, str]) -> None:
    text = pages[ROOT / "docs" / "reference" / "cli.md"]
    ctx = click.Context(cli, info_name="chameleons")
    for name in COMMANDS:
        command = cli.get_command(ctx, name)
        assert command is not None
        section = text.split(f"\n## chameleons {name}\n", 1)[1].split("\n## ", 1)[0]
        sub_ctx = click.Context(command, info_name=name, parent=ctx)
        for option in _options(command, sub_ctx):
            assert f"`{option}`" in section, f"chameleons {name} {option} is not on the page"
        if isinstance(command, click.Group):
            for sub in command.list_commands(sub_ctx):
                assert f"### chameleons {name} {sub}\n" in section


def test_settings_page_lists_every_setting_with_its_variable(pages: dict[Path, str]) -> None:
    text = pages[ROOT / "docs" / "reference" / "settings.md"]
    for name in Settings.model_fields:
        assert f"| `CHAMELEONS_{name.upper()}` |" in text
    assert "| `CHAMELEONS_PORT` | int (>= 1, <= 65535) | `8000` |" in text


def test_the_cli_page_does_not_depend_on_a_command_run_before(generator: ModuleType) -> None:
    """A test that runs one command on its own (not through the group, so without its
    ``-h``) makes click keep that command's help option as ``--help`` alone; the page
    generated after it is the same page."""
    before = generator.cli_page()
    ctx = click.Context(cli, info_name="chameleons", **cli.context_settings)
    for name in ("analyze", "export"):
        command = cli.get_command(ctx, name)
        assert command is not None
        result = CliRunner().invoke(command, ["--help"])
        assert result.exit_code == 0, result.output
    assert generator.cli_page() == before
