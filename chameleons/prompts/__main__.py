"""Check prompt catalogues without starting the server: ``python -m chameleons.prompts DIR``.

DIR is a catalogue root (one sub-directory per actor) or a single actor directory. Prints
one line per problem (``file:line: message``) and exits 1 when there is any.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from chameleons.prompts.loader import CatalogueError, load_catalogue, load_catalogues
from chameleons.prompts.manifest import MANIFEST_NAME


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m chameleons.prompts", description=__doc__)
    parser.add_argument("directory", type=Path, nargs="?", default=Path("prompts"))
    args = parser.parse_args(argv)
    directory: Path = args.directory
    try:
        if (directory / MANIFEST_NAME).is_file():
            catalogues = {directory.name: load_catalogue(directory)}
        else:
            catalogues = load_catalogues(directory)
    except CatalogueError as error:
        print("\n".join(error.problems), file=sys.stderr)
        return 1
    for actor, catalogue in catalogues.items():
        recorded = sum(prompt.audio is not None for prompt in catalogue.prompts)
        print(f"{actor}: {len(catalogue)} prompts, {recorded} with audio")
    return 0


if __name__ == "__main__":
    sys.exit(main())
