"""Write the demo's Swedish catalogue: ``prompts/sv/<actor>/`` for every demo actor.

The whole study in Swedish (the same prompts, ids and group names as the English demo: every
introduction, scenario, item description and question, every suggestion phrasing, reply,
transition and closing), written from ``prompts/_demo_source/sv/`` by
``scripts/write_demo_catalogue.py --language sv``; this script is that command. The voices
are espeak-ng's Swedish with each actor's pitch, speed and variant; then run

    .venv/bin/python scripts/synthesize_voices.py --root prompts/sv

Usage: ``.venv/bin/python scripts/write_swedish_demo.py [--root prompts] [--check]``
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

LANGUAGE = "sv"


def main(argv: list[str] | None = None) -> int:
    path = Path(__file__).resolve().parent / "write_demo_catalogue.py"
    spec = importlib.util.spec_from_file_location("write_demo_catalogue", path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    arguments = list(sys.argv[1:] if argv is None else argv)
    return int(module.main(["--language", LANGUAGE, *arguments]))


if __name__ == "__main__":
    sys.exit(main())
