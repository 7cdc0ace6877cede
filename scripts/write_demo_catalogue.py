"""Write the demo prompt catalogue: ``prompts/<actor>/manifest.csv`` for m1, m2, f1, f2.

The content lives in ``prompts/_demo_source/``: ``items.yaml`` (what to say about each
item, in expert order) and ``phrasing.yaml`` (how each actor says things). Run this after
editing either; ``--check`` only reports whether the committed manifests are up to date.

Audio and lip-sync cells are filled in for files that already exist as
``<actor>/audio/<id>.<ext>`` and ``<actor>/lipsync/<id>.csv``, so re-running after the
voices are synthesised records them in the manifests.

Usage: ``.venv/bin/python scripts/write_demo_catalogue.py [--root prompts] [--check]``
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import permutations
from pathlib import Path
from typing import Any

import yaml

from chameleons.prompts import manifest_text

ACTORS = ("m1", "m2", "f1", "f2")
ROBOT_NAMES = ("Nova", "Milo", "Iris", "Theo", "Luna", "Oskar", "Vera", "Kai")
# The default item sets (expert ranks 3-7 "better", 8-12 "worse"): "put X above Y" prompts
# exist for every ordered pair inside one set; other moves use the generic prompts.
DEFAULT_SETS = (range(3, 8), range(8, 13))
AUDIO_EXTENSIONS = (".ogg", ".opus", ".mp3", ".m4a", ".wav")
SOURCE_DIR = "_demo_source"

Row = dict[str, str]


@dataclass(frozen=True)
class Item:
    task: str
    rank: int
    id: str
    name: str
    short: str
    why: str
    why_short: str
    plural: bool = False

    def fields(self) -> dict[str, str]:
        """Template fields for this item (README of the source: phrasing.yaml header)."""
        return {
            "name": self.name,
            "Name": _capitalise(self.name),
            "short": self.short,
            "Short": _capitalise(self.short),
            "why": self.why,
            "why_short": self.why_short,
            "it": "them" if self.plural else "it",
            "they": "they" if self.plural else "it",
            "is": "are" if self.plural else "is",
        }


def _capitalise(text: str) -> str:
    return text[:1].upper() + text[1:]


def load_items(path: Path) -> dict[str, list[Item]]:
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    return {
        task: [Item(task=task, rank=rank, **entry) for rank, entry in enumerate(entries, 1)]
        for task, entries in data.items()
    }


def actor_rows(phrasing: dict[str, Any], items: dict[str, list[Item]]) -> list[Row]:
    """Every prompt of one actor, in stage order."""
    rows: list[Row] = []
    for index, robot in enumerate(ROBOT_NAMES):
        text = _pick(phrasing["intro"], index).format(robot=robot)
        rows.append(_row(f"intro_{robot.lower()}", "intro", text, robot_name=robot))
    for task, variants in phrasing["scenario"].items():
        rows += _variants(f"{task}_scenario", "scenario", variants, task=task)
    all_items = [item for task_items in items.values() for item in task_items]
    rows += _item_rows(all_items, phrasing["describe"], "describe", "item_description")
    rows += _item_rows(all_items, phrasing["question"], "question", "item_question")
    rows += _variants("rank_instruction", "rank_instruction", phrasing["rank_instruction"])
    rows += _item_rows(all_items, phrasing["move_up"], "move_up", "suggestion")
    rows += _item_rows(all_items, phrasing["make_first"], "make_first", "suggestion")
    rows += _item_rows(all_items, phrasing["move_down"], "move_down", "suggestion")
    rows += _pair_rows(items, phrasing["above"])
    for stage in ("acknowledgement", "transition"):
        for group, variants in phrasing[stage].items():
            rows += _variants(group, stage, variants)
    for stage in ("repeat", "cannot_answer", "closing"):
        rows += _variants(stage, stage, phrasing[stage])
    return rows


def _item_rows(items: list[Item], templates: list[str], suffix: str, stage: str) -> list[Row]:
    return [
        _row(
            f"{item.task}_{item.id}_{suffix}",
            stage,
            _pick(templates, index).format(**item.fields()),
            task=item.task,
            item=item.id,
        )
        for index, item in enumerate(items)
    ]


def _pair_rows(items: dict[str, list[Item]], templates: list[str]) -> list[Row]:
    rows: list[Row] = []
    for task, task_items in items.items():
        for ranks in DEFAULT_SETS:
            item_set = [item for item in task_items if item.rank in ranks]
            for first, second in permutations(item_set, 2):
                text = _pick(templates, len(rows)).format(**first.fields(), other=second.short)
                group = f"{task}_{first.id}_above_{second.id}"
                rows.append(_row(group, "suggestion", text, task, first.id, second.id))
    return rows


def _variants(group: str, stage: str, texts: list[str], task: str = "") -> list[Row]:
    """A variant group; ids get a 1-based suffix when there is more than one variant."""
    if len(texts) == 1:
        return [_row(group, stage, texts[0], task=task)]
    return [
        _row(f"{group}_{n}", stage, text, task=task, group=group) for n, text in enumerate(texts, 1)
    ]


def _row(
    prompt_id: str,
    stage: str,
    text: str,
    task: str = "",
    item: str = "",
    other_item: str = "",
    *,
    robot_name: str = "",
    group: str = "",
) -> Row:
    return {
        "id": prompt_id,
        "stage": stage,
        "group": group or prompt_id,
        "text": text,
        "task": task,
        "item": item,
        "other_item": other_item,
        "robot_name": robot_name,
    }


def _pick(templates: list[str], index: int) -> str:
    return templates[index % len(templates)]


def with_existing_assets(actor_dir: Path, rows: list[Row]) -> Iterator[Row]:
    """Rows with audio/lipsync set for the files already present in the actor folder."""
    for row in rows:
        audio = next(
            (f"audio/{row['id']}{ext}" for ext in AUDIO_EXTENSIONS
             if (actor_dir / "audio" / f"{row['id']}{ext}").is_file()),
            "",
        )  # fmt: skip
        lipsync = f"lipsync/{row['id']}.csv"
        yield {**row, "audio": audio, "lipsync": lipsync if (actor_dir / lipsync).is_file() else ""}


def render_catalogue(root: Path) -> dict[Path, str]:
    """Manifest path -> its text, for every demo actor under ``root``."""
    source = root / SOURCE_DIR
    items = load_items(source / "items.yaml")
    phrasing = yaml.safe_load((source / "phrasing.yaml").read_text(encoding="utf-8"))
    return {
        root / actor / "manifest.csv": manifest_text(
            with_existing_assets(root / actor, actor_rows(phrasing[actor], items))
        )
        for actor in ACTORS
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--root", type=Path, default=Path(__file__).parents[1] / "prompts")
    parser.add_argument("--check", action="store_true", help="exit 1 if a manifest is stale")
    args = parser.parse_args(argv)
    stale: list[Path] = []
    for path, text in render_catalogue(args.root).items():
        current = path.read_text(encoding="utf-8") if path.is_file() else None
        if current == text:
            continue
        stale.append(path)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8", newline="")
        rows = len(text.splitlines()) - 1  # no demo text spans lines
        print(f"{'stale' if args.check else 'wrote'} {path} ({rows} prompts)")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
