"""``actor.yaml``: who the robot personality of an actor is, and hints for voice synthesis.

The file is optional (a catalogue of real recordings may not need voice hints); when it is
there it must be well-formed, so a typo does not silently drop a setting.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from chameleons.prompts.model import ActorProfile

GENDERS = ("male", "female", "other")
_KNOWN_KEYS = frozenset(
    {"display_name", "gender", "personality", "description", "voice", "language"}
)
_LANGUAGE = re.compile(r"^[a-z]{2,3}(-[A-Za-z0-9]{2,8})?$")


def load_profile(path: Path, actor: str) -> tuple[ActorProfile, list[str]]:
    """The profile in ``path`` (defaults when the file is absent) and its problems."""
    default = ActorProfile(actor=actor, display_name=actor)
    if not path.is_file():
        return default, []
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeError, yaml.YAMLError) as error:
        return default, [f"{path}: cannot read actor profile: {_one_line(error)}"]
    if data is None:
        return default, []
    if not isinstance(data, dict):
        return default, [f"{path}: expected a mapping of settings, not {type(data).__name__}"]
    problems = [f"{path}: unknown setting '{key}'" for key in data if key not in _KNOWN_KEYS]
    problems += _check_values(path, data)
    if problems:
        return default, problems
    return ActorProfile(
        actor=actor,
        display_name=str(data.get("display_name") or actor),
        gender=data.get("gender"),
        personality=data.get("personality"),
        description=str(data.get("description") or "").strip(),
        voice=dict(data.get("voice") or {}),
        language=str(data.get("language") or "en"),
    ), []


def _check_values(path: Path, data: dict[str, Any]) -> list[str]:
    problems: list[str] = []
    gender = data.get("gender")
    if gender is not None and gender not in GENDERS:
        problems.append(f"{path}: gender '{gender}' is not one of {', '.join(GENDERS)}")
    for key in ("display_name", "personality", "description"):
        if data.get(key) is not None and not isinstance(data[key], str):
            problems.append(f"{path}: {key} must be text")
    language = data.get("language")
    if language is not None and not (isinstance(language, str) and _LANGUAGE.match(language)):
        problems.append(f"{path}: language must be a language code such as en or sv")
    voice = data.get("voice")
    if voice is not None and not (
        isinstance(voice, dict)
        and all(
            isinstance(v, str | int | float) and not isinstance(v, bool) for v in voice.values()
        )
    ):
        problems.append(f"{path}: voice must map names to text or numbers")
    return problems


def _one_line(error: Exception) -> str:
    return " ".join(str(error).split())
