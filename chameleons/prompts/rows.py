"""Checks of single manifest rows and of rows against each other (ids, variant groups)."""

from __future__ import annotations

import re
from collections.abc import Collection, Mapping
from pathlib import Path, PurePosixPath

from chameleons.prompts.manifest import ManifestRow
from chameleons.prompts.model import ITEM_STAGES, Prompt, Stage, estimate_duration, item_ref

# Ids end up in file names, URLs and event logs: keep them plain.
_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
_STAGES = ", ".join(stage.value for stage in Stage)
# Variants of one group must agree on these, or picking one at random changes the meaning.
_GROUP_FIELDS = ("stage", "task", "item", "other_item", "robot_name")


class RowChecker:
    """Turns manifest rows into prompts, collecting ``file:line: message`` problems."""

    def __init__(
        self,
        manifest: Path,
        actor_dir: Path,
        known_items: Mapping[str, Collection[str]] | None,
        robot_names: Collection[str] | None,
    ) -> None:
        self.manifest = manifest
        self.actor_dir = actor_dir
        self.known_items = known_items
        self.robot_names = robot_names
        self.problems: list[str] = []
        self._id_lines: dict[str, int] = {}
        self._group_first: dict[str, Prompt] = {}

    def check(self, row: ManifestRow) -> Prompt | None:
        """The row's prompt, or None when it is too broken to build one."""
        line = row.line
        cell = row.cells.get
        if row.extra_cells:
            self._report(line, f"{row.extra_cells} cell(s) beyond the header (a stray comma?)")
        prompt_id = self._check_id(line, cell("id", ""))
        stage = self._check_stage(line, cell("stage", ""))
        text = cell("text", "")
        if not text:
            self._report(line, "empty text")
        task, item, other = (cell(name, "") or None for name in ("task", "item", "other_item"))
        self._check_items(line, stage, task, item, other)
        robot_name = cell("robot_name", "") or None
        if robot_name and self.robot_names is not None and robot_name not in self.robot_names:
            self._report(line, f"unknown robot_name '{robot_name}'")
        audio = self._check_file(line, "audio", cell("audio", ""))
        lipsync = self._check_file(line, "lipsync", cell("lipsync", ""))
        if prompt_id is None or stage is None:
            return None
        prompt = Prompt(
            id=prompt_id,
            stage=stage,
            group=cell("group", "") or prompt_id,
            text=text,
            task=task,
            item=item,
            other_item=other,
            robot_name=robot_name,
            audio=audio,
            lipsync=lipsync,
            estimated_duration=estimate_duration(text),
            line=line,
        )
        self._check_group(prompt)
        return prompt

    def _report(self, line: int, message: str) -> None:
        self.problems.append(f"{self.manifest}:{line}: {message}")

    def _check_id(self, line: int, prompt_id: str) -> str | None:
        if not prompt_id:
            self._report(line, "empty id")
            return None
        if not _ID.match(prompt_id):
            self._report(line, f"id '{prompt_id}' may only use letters, digits, '_', '-', '.'")
        first = self._id_lines.setdefault(prompt_id, line)
        if first != line:
            self._report(line, f"duplicate id '{prompt_id}' (first on line {first})")
            return None
        return prompt_id

    def _check_stage(self, line: int, value: str) -> Stage | None:
        if not value:
            self._report(line, "empty stage")
            return None
        try:
            return Stage(value.lower())
        except ValueError:
            self._report(line, f"unknown stage '{value}' (expected one of: {_STAGES})")
            return None

    def _check_items(
        self, line: int, stage: Stage | None, task: str | None, item: str | None, other: str | None
    ) -> None:
        if item and not task:
            self._report(line, f"item '{item}' without a task")
        if other and not item:
            self._report(line, f"other_item '{other}' without an item")
        if other and stage is not None and stage is not Stage.SUGGESTION:
            self._report(line, "other_item is only used by suggestion prompts")
        if other and other == item:
            self._report(line, f"other_item '{other}' is the item itself")
        if stage in ITEM_STAGES and not (task and item):
            self._report(line, f"stage '{stage}' needs a task and an item")
        if self.known_items is None or not task:
            return
        if task not in self.known_items:
            self._report(line, f"unknown task '{task}'")
            return
        for column, value in (("item", item), ("other_item", other)):
            if value and value not in self.known_items[task]:
                self._report(line, f"unknown {column} '{item_ref(task, value)}'")

    def _check_file(self, line: int, column: str, value: str) -> PurePosixPath | None:
        if not value:
            return None
        relative = PurePosixPath(value.replace("\\", "/"))
        if relative.is_absolute() or ".." in relative.parts or ":" in value:
            self._report(line, f"{column} path '{value}' must be relative to the actor folder")
            return None
        if not self.actor_dir.joinpath(*relative.parts).is_file():
            self._report(line, f"{column} file '{value}' not found in {self.actor_dir}")
        return relative

    def _check_group(self, prompt: Prompt) -> None:
        first = self._group_first.setdefault(prompt.group, prompt)
        differing = [n for n in _GROUP_FIELDS if getattr(prompt, n) != getattr(first, n)]
        if differing:
            self._report(
                prompt.line,
                f"group '{prompt.group}' differs from its first prompt (line {first.line}) "
                f"in {', '.join(differing)}: variants must be interchangeable",
            )
