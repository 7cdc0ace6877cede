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


def study_yaml(document: dict[str, Any]) -> str:
    return yaml.safe_dump(document, sort_keys=False, allow_unicode=True)


def with_natural(**params: Any) -> str:
    """The default study's YAML with other ``natural`` parameters (e.g. source=yoked)."""
    document = default_document()
    document["conditions"]["natural"]["params"] = params
    return study_yaml(document)


def with_german(document: dict[str, Any]) -> dict[str, Any]:
    """``document`` declaring German too, with a German text beside every Swedish one."""

    def walk(node: Any) -> Any:
        if isinstance(node, dict):
            if set(node) == {"en", "sv"}:
                return {**node, "de": f"{node['en']} (de)"}
            return {key: walk(value) for key, value in node.items()}
        if isinstance(node, list):
            return [walk(value) for value in node]
        return node

    return {**walk(document), "languages": ["en", "sv", "de"]}


def write_study(directory: Path, document: dict[str, Any], name: str = "study.yaml") -> Path:
    path = directory / name
    path.write_text(yaml.safe_dump(document, sort_keys=False, allow_unicode=True), "utf-8")
    return path


def four_condition_document() -> dict[str, Any]:
    """The default study with a fourth condition (sessions then use all 4 actors and faces)."""
    document = default_document()
    document["conditions"]["copy_fast"] = {
        "label": "Copy 1 s",
        "behaviour": "copy",
        "params": {"delay": 1.0},
    }
    return document


def laughs(levels: int, width: int = 9) -> str:
    """``levels`` lists of ``width`` aliases of the list before: width**levels values from
    a few hundred bytes."""
    lines = [f"laugh0: &laugh0 [{', '.join(['lol'] * width)}]"]
    for level in range(1, levels):
        aliases = ", ".join([f"*laugh{level - 1}"] * width)
        lines.append(f"laugh{level}: &laugh{level} [{aliases}]")
    return "\n".join(lines) + "\n"
