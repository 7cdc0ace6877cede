"""Load and validate prompt catalogues; every problem is reported with its file and line.

Validation collects all problems of all files before raising one ``CatalogueError``, so a
lab fixes its spreadsheet in one pass instead of one error per run.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from pathlib import Path

from chameleons.locations import actor_directories as actor_directories
from chameleons.prompts.catalogue import Catalogue
from chameleons.prompts.manifest import (
    ACTOR_PROFILE_NAME,
    MANIFEST_NAME,
    REQUIRED_COLUMNS,
    ManifestSyntaxError,
    read_manifest,
)
from chameleons.prompts.model import Prompt
from chameleons.prompts.profile import load_profile
from chameleons.prompts.rows import RowChecker


class CatalogueError(ValueError):
    """A catalogue that cannot be used; ``problems`` holds one ``file:line: message`` each."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        count = len(self.problems)
        summary = f"{count} problem{'s' if count != 1 else ''} in the prompt catalogue"
        super().__init__("\n".join([summary + ":", *self.problems]))


KnownItems = Mapping[str, Collection[str]]


def load_catalogue(
    actor_dir: Path,
    known_items: KnownItems | None = None,
    *,
    robot_names: Collection[str] | None = None,
    language_folder: str | None = None,
) -> Catalogue:
    """Load ``actor_dir/manifest.csv`` (and ``actor.yaml`` when present), validated.

    ``known_items`` maps task id -> item ids; when given, every task/item/other_item must
    be one of them. ``robot_names``, when given, limits the ``robot_name`` column likewise.
    ``language_folder`` names the language folder ``actor_dir`` lies in
    (``prompts/<language_folder>/<actor>/``; None: the actor's own folder).
    """
    prompts, problems = _load_prompts(actor_dir, known_items, robot_names)
    profile, profile_problems = load_profile(actor_dir / ACTOR_PROFILE_NAME, actor_dir.name)
    problems += profile_problems
    if problems:
        raise CatalogueError(problems)
    return Catalogue(actor_dir.name, actor_dir, profile, prompts, language_folder=language_folder)


def load_catalogues(
    root: Path,
    known_items: KnownItems | None = None,
    *,
    robot_names: Collection[str] | None = None,
) -> dict[str, Catalogue]:
    """Every actor under ``root`` (each sub-directory with a manifest), keyed by actor id."""
    actor_dirs = actor_directories(root)
    if not actor_dirs:
        raise CatalogueError([f"{root}: no actor directories with a {MANIFEST_NAME}"])
    catalogues: dict[str, Catalogue] = {}
    problems: list[str] = []
    for actor_dir in actor_dirs:
        try:
            catalogues[actor_dir.name] = load_catalogue(
                actor_dir, known_items, robot_names=robot_names
            )
        except CatalogueError as error:
            problems += error.problems
    if problems:
        raise CatalogueError(problems)
    return catalogues


def _load_prompts(
    actor_dir: Path, known_items: KnownItems | None, robot_names: Collection[str] | None
) -> tuple[list[Prompt], list[str]]:
    path = actor_dir / MANIFEST_NAME
    try:
        table = read_manifest(path)
    except FileNotFoundError:
        return [], [f"{path}: manifest not found"]
    except ManifestSyntaxError as error:
        return [], [f"{path}:{error.line}: {error}"]
    except (OSError, UnicodeError) as error:
        return [], [f"{path}: cannot read manifest: {error}"]
    missing = [column for column in REQUIRED_COLUMNS if column not in table.header]
    if missing:
        return [], [f"{path}:1: missing required column '{column}'" for column in missing]
    checker = RowChecker(path, actor_dir, known_items, robot_names)
    prompts = [prompt for row in table.rows if (prompt := checker.check(row)) is not None]
    return prompts, checker.problems
