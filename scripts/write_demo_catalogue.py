"""Write the demo prompt catalogue: ``prompts/<actor>/manifest.csv`` for m1, m2, f1, f2.

The content lives in ``prompts/_demo_source/``: ``items.yaml`` (what to say about each
item, in expert order) and ``phrasing.yaml`` (how each actor says things). Run this after
editing either; ``--check`` only reports whether the committed manifests are up to date.

``--language sv`` writes the same catalogue in another language from
``prompts/_demo_source/sv/`` (the same structure, the same ids and group names) into
``prompts/sv/<actor>/``, with an ``actor.yaml`` made from the English one (espeak-ng's
voice of that language, the same pitch, speed and variant).

Audio and lip-sync cells are filled in for files that already exist as
``<actor>/audio/<id>.<ext>`` and ``<actor>/lipsync/<id>.csv``, so re-running after the
voices are synthesised records them in the manifests.

Usage: ``.venv/bin/python scripts/write_demo_catalogue.py [--root prompts] [--language sv]
[--check]``
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

from chameleons.i18n import language_name
from chameleons.prompts import manifest_text

ACTORS = ("m1", "m2", "f1", "f2")
ROBOT_NAMES = ("Nova", "Milo", "Iris", "Theo", "Luna", "Oskar", "Vera", "Kai")
# The default item sets (expert ranks 3-7 "better", 8-12 "worse"): "put X above Y" prompts
# exist for every ordered pair inside one set; other moves use the generic prompts.
DEFAULT_SETS = (range(3, 8), range(8, 13))
AUDIO_EXTENSIONS = (".ogg", ".opus", ".mp3", ".m4a", ".wav")
SOURCE_DIR = "_demo_source"
ENGLISH = "en"

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
    gender: str = ""  # Swedish: "ett" for ett-words (en-words need nothing)
    language: str = ENGLISH

    def fields(self) -> dict[str, str]:
        """Template fields for this item (README of the source: phrasing.yaml header)."""
        return {
            "name": self.name,
            "Name": _capitalise(self.name),
            "short": self.short,
            "Short": _capitalise(self.short),
            "why": self.why,
            "why_short": self.why_short,
            **self.pronouns(),
        }

    def pronouns(self) -> dict[str, str]:
        """``it`` (object), ``they`` (subject) and ``is`` for this item in its language."""
        if self.language == "sv":
            it = "dem" if self.plural else "det" if self.gender == "ett" else "den"
            return {"it": it, "they": "de" if self.plural else it, "is": "är"}
        return {"it": "them" if self.plural else "it", "they": "they" if self.plural else "it",
                "is": "are" if self.plural else "is"}  # fmt: skip


def _capitalise(text: str) -> str:
    return text[:1].upper() + text[1:]


def load_items(path: Path, language: str = ENGLISH) -> dict[str, list[Item]]:
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    return {
        task: [Item(task=task, rank=rank, language=language, **entry)
               for rank, entry in enumerate(entries, 1)]
        for task, entries in data.items()
    }  # fmt: skip


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


def render_catalogue(root: Path, language: str = ENGLISH) -> dict[Path, str]:
    """File path -> its text: every demo actor's manifest under ``root`` (in ``language``:
    under ``root/<language>``, with the actor's ``actor.yaml`` for that language)."""
    english = language == ENGLISH
    source = root / SOURCE_DIR if english else root / SOURCE_DIR / language
    target = root if english else root / language
    items = load_items(source / "items.yaml", language)
    phrasing = yaml.safe_load((source / "phrasing.yaml").read_text(encoding="utf-8"))
    files = {
        target / actor / "manifest.csv": manifest_text(
            with_existing_assets(target / actor, actor_rows(phrasing[actor], items))
        )
        for actor in ACTORS
    }
    if not english:
        files |= {target / actor / "actor.yaml": profile_text(root / actor, language)
                  for actor in ACTORS}  # fmt: skip
    return files


def profile_text(english: Path, language: str) -> str:
    """The English actor's ``actor.yaml`` in ``language``: espeak-ng's voice of that
    language with the English voice's variant (``en-gb-x-rp+m3`` -> ``sv+m3``), the same
    pitch, speed and gaps."""
    data = yaml.safe_load((english / "actor.yaml").read_text(encoding="utf-8"))
    voice = dict(data["voice"])
    variant = str(voice["espeak_voice"]).rpartition("+")[2]
    voice["espeak_voice"] = f"{language}+{variant}"
    profile = {**data, "display_name": f"{data['display_name']} ({language_name(language)})",
               "language": language, "voice": voice}  # fmt: skip
    header = (f"# The {language} prompts of actor {english.name} "
              f"(scripts/write_demo_catalogue.py --language {language}).\n")  # fmt: skip
    return header + yaml.safe_dump(profile, allow_unicode=True, sort_keys=False)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--root", type=Path, default=Path(__file__).parents[1] / "prompts")
    parser.add_argument("--language", default=ENGLISH,
                        help="write the catalogue in this language (source: "
                        "_demo_source/<language>/, target: <language>/<actor>/)")  # fmt: skip
    parser.add_argument("--check", action="store_true", help="exit 1 if a manifest is stale")
    args = parser.parse_args(argv)
    stale: list[Path] = []
    for path, text in render_catalogue(args.root, args.language).items():
        current = path.read_text(encoding="utf-8") if path.is_file() else None
        if current == text:
            continue
        stale.append(path)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8", newline="")
        rows = len(text.splitlines()) - 1  # no demo text spans lines
        what = f"{rows} prompts" if path.suffix == ".csv" else "profile"
        print(f"{'stale' if args.check else 'wrote'} {path} ({what})")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
