"""Write the demo's Swedish prompt subset: ``prompts/sv/<actor>/`` for every demo actor.

A small set (introductions, scenarios, the script's transitions, a few replies and the
closing) is enough for a session in Swedish: the console offers these and lists the rest
as having no Swedish recording (the wizard types them in the Say field). Group names match
the English catalogue's, so the console's buttons and shortcuts are the same. The voices
are espeak-ng's Swedish with each actor's pitch and speed; then run

    .venv/bin/python scripts/synthesize_voices.py --root prompts/sv

Usage: ``.venv/bin/python scripts/write_swedish_demo.py [--root prompts]``
"""

from __future__ import annotations

import argparse
import csv
import io
from pathlib import Path

import yaml

from chameleons.prompts import load_catalogue
from chameleons.prompts.manifest import MANIFEST_COLUMNS

ROOT = Path(__file__).resolve().parent.parent
LANGUAGE = "sv"
NAMES = ("Nova", "Milo", "Iris", "Theo", "Luna", "Oskar", "Vera", "Kai")
INTRO = "Hej, jag heter {name}. Vad roligt att du är här. Vi löser det här tillsammans."
# group -> (stage, task, text)
SCRIPT: dict[str, tuple[str, str, str]] = {
    "lunar_scenario": (
        "scenario",
        "lunar",
        "Vårt rymdskepp har nödlandat på månens solsida, trehundratjugo kilometer från "
        "moderskeppet. Låt oss tillsammans bestämma vilka föremål som hjälper oss mest.",
    ),
    "desert_scenario": (
        "scenario",
        "desert",
        "Vårt lilla flygplan har nödlandat i öknen, långt från den planerade rutten. Låt oss "
        "tillsammans bestämma vilka föremål som hjälper oss mest.",
    ),
    "rank_instruction": (
        "rank_instruction",
        "",
        "Ta nu telefonen och ordna föremålen så som du tycker är bäst.",
    ),
    "first_item": ("transition", "", "Vi börjar med det första föremålet."),
    "next_item": ("transition", "", "Nu tittar vi på nästa föremål."),
    "review_ranking": ("transition", "", "Tack. Nu går vi igenom din rangordning tillsammans."),
    "start_suggestions": ("transition", "", "Jag har några förslag, om det går bra för dig."),
    "ack_yes": ("acknowledgement", "", "Ja, det tycker jag också."),
    "ack_no": ("acknowledgement", "", "Nej, det tror jag inte."),
    "ack_okay": ("acknowledgement", "", "Okej, tack."),
    "repeat": ("repeat", "", "Förlåt, jag hörde inte riktigt. Kan du säga det igen?"),
    "closing": (
        "closing",
        "",
        "Tack för att du arbetade tillsammans med mig. Svara nu på frågorna på telefonen.",
    ),
}


def rows() -> list[dict[str, str]]:
    table = [
        {"id": f"intro_{n.lower()}", "stage": "intro", "group": f"intro_{n.lower()}",
         "text": INTRO.format(name=n), "robot_name": n}
        for n in NAMES
    ]  # fmt: skip
    for group, (stage, task, text) in SCRIPT.items():
        table.append({"id": group, "stage": stage, "group": group, "text": text, "task": task})
    return table


def manifest(actor_dir: Path) -> str:
    """The Swedish manifest, keeping audio/lip-sync cells already synthesised."""
    existing = {}
    if (actor_dir / "manifest.csv").is_file():
        with (actor_dir / "manifest.csv").open(encoding="utf-8-sig", newline="") as handle:
            existing = {row["id"]: row for row in csv.DictReader(handle)}
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=MANIFEST_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows():
        kept = existing.get(row["id"], {})
        same_text = kept.get("text") == row["text"]
        assets = {k: kept.get(k, "") if same_text else "" for k in ("audio", "lipsync")}
        writer.writerow(dict.fromkeys(MANIFEST_COLUMNS, "") | row | assets)
    return buffer.getvalue()


def profile(english: Path) -> dict[str, object]:
    """The English actor's profile with espeak-ng's Swedish voice and the same pitch."""
    data = yaml.safe_load((english / "actor.yaml").read_text(encoding="utf-8"))
    voice = dict(data["voice"])
    variant = str(voice["espeak_voice"]).rpartition("+")[2]
    voice["espeak_voice"] = f"{LANGUAGE}+{variant}"
    return {**data, "display_name": f"{data['display_name']} (svenska)", "language": LANGUAGE,
            "voice": voice}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=ROOT / "prompts")
    args = parser.parse_args()
    for english in sorted(p for p in args.root.iterdir() if (p / "actor.yaml").is_file()):
        target = args.root / LANGUAGE / english.name
        target.mkdir(parents=True, exist_ok=True)
        header = f"# Swedish prompts of actor {english.name} (scripts/write_swedish_demo.py).\n"
        text = yaml.safe_dump(profile(english), allow_unicode=True, sort_keys=False)
        (target / "actor.yaml").write_text(header + text, encoding="utf-8")
        (target / "manifest.csv").write_text(manifest(target), encoding="utf-8")
        print(f"{target}: {len(load_catalogue(target))} prompts")


if __name__ == "__main__":
    main()
