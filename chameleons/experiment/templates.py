"""The shipped study templates: every folder under ``chameleons/experiment/studies/`` with a
``study.yaml`` (docs/design-space.md gives each one's rationale)."""

from __future__ import annotations

from pathlib import Path

STUDIES = Path(__file__).resolve().parent / "studies"


def study_templates() -> dict[str, Path]:
    """Template name (its folder) -> its study file, by name."""
    return {p.parent.name: p for p in sorted(STUDIES.glob("*/study.yaml"))}
