"""Helpers for tests that need variants of the default study written to a temporary file."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import yaml

from chameleons.experiment.study import default_study_path


def default_document() -> dict[str, Any]:
    """The default study file parsed as plain YAML (a fresh copy each call)."""
    with default_study_path().open(encoding="utf-8") as handle:
        return copy.deepcopy(yaml.safe_load(handle))


def write_study(directory: Path, document: dict[str, Any], name: str = "study.yaml") -> Path:
    path = directory / name
    path.write_text(yaml.safe_dump(document, sort_keys=False, allow_unicode=True), "utf-8")
    return path


def four_condition_document() -> dict[str, Any]:
    """The default study with a fourth condition (sessions then use all 4 actors and faces)."""
    document = default_document()
    document["conditions"]["exaggerated"] = {"label": "Exaggerated copy"}
    return document
