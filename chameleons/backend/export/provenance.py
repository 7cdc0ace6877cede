"""Where every exported number comes from: the study configuration (and how to recompute
its hash), the plan's seed and planner version, the software (package version and git
commit), and the prompt catalogues. Written into ``metadata.json`` and described in the
codebook (table ``metadata.json``)."""

from __future__ import annotations

import functools
import hashlib
import subprocess
from pathlib import Path
from typing import Any

from chameleons import __version__
from chameleons.backend.models import Study
from chameleons.experiment.design import PLANNER_VERSION
from chameleons.experiment.model import Study as StudySpec
from chameleons.prompts.manifest import ACTOR_PROFILE_NAME, MANIFEST_NAME

PACKAGE_DIR = Path(__file__).resolve().parents[2]
HASH_RECIPE = (
    "sha256 (hex) of the UTF-8 bytes of the JSON in study_config.json re-serialised "
    "canonically: Python json.dumps(config, sort_keys=True, separators=(',', ':'), "
    "ensure_ascii=False)."
)
CATALOGUE_NOTE = (
    "sha256 (first 16 hex digits) of each actor's manifest.csv and actor.yaml bytes and "
    "the names and sizes of its audio and lip-sync files, as found in the prompts folder "
    "at export time; a catalogue changed since the sessions ran shows a different value."
)


@functools.cache
def software_commit() -> str | None:
    """``git describe --always --dirty --abbrev=40`` of the installed source, or None when
    it is not a git checkout (a wheel, the Docker image) or git is missing."""
    try:
        done = subprocess.run(
            ["git", "-C", str(PACKAGE_DIR), "describe", "--always", "--dirty", "--abbrev=40"],
            capture_output=True, text=True, timeout=10, check=False,
        )  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return None
    text = done.stdout.strip()
    return text if done.returncode == 0 and text else None


def catalogue_version(actor_dir: Path) -> str | None:
    if not (actor_dir / MANIFEST_NAME).is_file():
        return None
    digest = hashlib.sha256()
    for name in (MANIFEST_NAME, ACTOR_PROFILE_NAME):
        path = actor_dir / name
        digest.update(name.encode() + b"\0" + (path.read_bytes() if path.is_file() else b""))
    for path in sorted(actor_dir.rglob("*")):
        if path.is_file() and path.name not in (MANIFEST_NAME, ACTOR_PROFILE_NAME):
            relative = path.relative_to(actor_dir).as_posix()
            digest.update(f"{relative}\0{path.stat().st_size}\n".encode())
    return digest.hexdigest()[:16]


def language_catalogues(spec: StudySpec, prompts_dir: Path) -> dict[str, dict[str, str | None]]:
    """Language -> actor id -> catalogue version of ``prompts/<language>/<actor>/``, the
    prompts a session in that language played, for each declared language that has any."""
    found = {
        language: {
            actor.id: catalogue_version(prompts_dir / language / actor.id) for actor in spec.actors
        }
        for language in spec.languages
    }
    return {language: versions for language, versions in found.items()
            if any(version is not None for version in versions.values())}  # fmt: skip


def provenance(study: Study, spec: StudySpec, prompts_dir: Path) -> dict[str, Any]:
    return {
        "study_config_hash_recipe": HASH_RECIPE,
        "plan_seed": study.plan_seed,
        "planner_version": PLANNER_VERSION,
        "software_version": __version__,
        "software_commit": software_commit(),
        "prompts_folder": str(prompts_dir),
        "prompt_catalogues": {
            actor.id: catalogue_version(prompts_dir / actor.id) for actor in spec.actors
        },
        "prompt_catalogues_by_language": language_catalogues(spec, prompts_dir),
        "prompt_catalogue_version_recipe": CATALOGUE_NOTE,
    }


PROVENANCE_CODEBOOK: tuple[tuple[str, str, str], ...] = (
    (
        "study_config_hash",
        "string",
        "Identifies the study configuration the data were collected under; recompute it from "
        "study_config.json with study_config_hash_recipe.",
    ),
    ("study_config_hash_recipe", "string", "How to recompute study_config_hash."),
    (
        "plan_seed",
        "integer",
        "The seed of the counterbalancing plan: the plan rows are reproduced by chameleons plan "
        "with this study, seed and planner_version.",
    ),
    ("planner_version", "string", "The planner's algorithm version."),
    ("software_version", "string", "The mechanical-chameleons package version."),
    (
        "software_commit",
        "string",
        "git describe --always --dirty of the software; empty when not run from a git checkout "
        "('-dirty': with uncommitted changes).",
    ),
    ("prompt_catalogues", "object", "Actor id -> prompt catalogue version (see the recipe)."),
    (
        "prompt_catalogues_by_language",
        "object",
        "Language -> actor id -> version of the actor's catalogue in that language "
        "(prompts/<language>/<actor>/, played in sessions in that language; see the recipe).",
    ),
    ("prompt_catalogue_version_recipe", "string", "What a prompt catalogue version covers."),
)


def provenance_codebook() -> list[dict[str, object]]:
    return [
        {"table": "metadata.json", "column": key, "type": kind, "description": text,
         "values": "", "possibly_identifying": False}
        for key, kind, text in PROVENANCE_CODEBOOK
    ]  # fmt: skip
