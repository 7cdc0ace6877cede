"""Typed reading of an untrusted, parsed document that collects every problem with its place.

Places are dotted paths: mapping keys and ids of keyed collections are joined with ``.``,
list positions are written ``[i]`` (e.g. ``tasks.lunar.items[3].expert_rank``).
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

SLUG = re.compile(r"^[a-z0-9][a-z0-9_-]*$")
SNAKE = re.compile(r"^[a-z][a-z0-9_]*$")


def join(path: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else key


class Reader:
    """Collects problems while reading; readers return a fallback value on a problem so the
    whole document is still checked in one pass."""

    def __init__(self) -> None:
        self.problems: list[str] = []

    def problem(self, path: str, message: str) -> None:
        self.problems.append(f"{path or '(top level)'}: {message}")

    def mapping(self, node: object, path: str) -> dict[str, Any]:
        if isinstance(node, Mapping):
            return {str(k): v for k, v in node.items()}
        self.problem(path, f"must be a mapping, got {_kind(node)}")
        return {}

    def sequence(self, node: object, path: str) -> list[Any]:
        if isinstance(node, Sequence) and not isinstance(node, str | bytes):
            return list(node)
        self.problem(path, f"must be a list, got {_kind(node)}")
        return []

    def check_keys(
        self, node: Mapping[str, Any], path: str, required: Sequence[str], optional: Sequence[str]
    ) -> None:
        for key in required:
            if key not in node:
                self.problem(join(path, key), "is missing")
        known = set(required) | set(optional)
        for key in node:
            if key not in known:
                self.problem(join(path, key), f"unknown key (expected one of {sorted(known)})")

    def text(
        self,
        node: Mapping[str, Any],
        key: str,
        path: str,
        default: str | None = None,
        *,
        allow_empty: bool = False,
    ) -> str:
        value = node.get(key, default)
        if value is None:
            return ""  # a missing required key was already reported by check_keys
        if not isinstance(value, str) or not (value.strip() or allow_empty):
            self.problem(join(path, key), f"must be a non-empty text, got {_kind(value)}")
            return ""
        return value.strip()

    def integer(
        self,
        node: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: int | None = None,
        minimum: int | None = None,
        maximum: int | None = None,
    ) -> int:
        value = node.get(key, default)
        if value is None:
            return minimum or 0
        if isinstance(value, bool) or not isinstance(value, int):
            self.problem(join(path, key), f"must be a whole number, got {_kind(value)}")
            return minimum or 0
        if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
            bounds = f"{'' if minimum is None else minimum}..{'' if maximum is None else maximum}"
            self.problem(join(path, key), f"must be in {bounds}, got {value}")
        return int(value)

    def boolean(self, node: Mapping[str, Any], key: str, path: str, *, default: bool) -> bool:
        value = node.get(key, default)
        if not isinstance(value, bool):
            self.problem(join(path, key), f"must be true or false, got {_kind(value)}")
            return default
        return value

    def identifier(self, value: object, path: str, pattern: re.Pattern[str] = SLUG) -> str:
        if not isinstance(value, str) or not pattern.match(value):
            style = "snake_case" if pattern is SNAKE else "lower-case letters, digits, _ or -"
            self.problem(path, f"id {value!r} must be {style}")
            return str(value)
        return value

    def keyed(
        self, node: object, path: str, pattern: re.Pattern[str] = SLUG
    ) -> Iterator[tuple[str, dict[str, Any], str]]:
        """Entries of a collection keyed by id: either a mapping ``id: {...}`` (study files)
        or a list of mappings with an ``id`` field (config snapshots). Yields (id, body, path)
        with ``id`` removed from the body."""
        if isinstance(node, Mapping):
            entries = [(str(k), v) for k, v in node.items()]
        elif isinstance(node, list):
            entries = []
            for index, element in enumerate(node):
                body = self.mapping(element, join(path, index))
                entries.append((str(body.get("id", f"[{index}]")), {"id": None, **body}))
        else:
            self.problem(path, f"must be a mapping of id to entry, got {_kind(node)}")
            return
        seen: set[str] = set()
        for entry_id, element in entries:
            place = join(path, entry_id)
            self.identifier(entry_id, place, pattern)
            if entry_id in seen:
                self.problem(place, f"id {entry_id!r} used twice")
            seen.add(entry_id)
            body = self.mapping({} if element is None else element, place)
            body.pop("id", None)
            yield entry_id, body, place


def _kind(value: object) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, str):
        return f"text {value!r}"
    return f"{type(value).__name__} {value!r}"[:80]


def optional_text(reader: Reader, body: dict[str, Any], key: str, place: str) -> str:
    """An optional text of ``body``: empty when absent or empty."""
    return reader.text(body, key, place, default="", allow_empty=True)
