"""Where files live on this machine: :mod:`chameleons.locations`, re-exported here.

The worker resolves marked paths too, and the worker sits below the prompt catalogue (whose
importer reads the worker's takes), so the path logic lives at the bottom of the layers.
"""

from chameleons.locations import (
    DATA_MARKER,
    PROMPTS_MARKER,
    REPOSITORY_PROMPTS,
    marked_path,
    prompts_root,
    resolve_marked_path,
)

__all__ = [
    "DATA_MARKER",
    "PROMPTS_MARKER",
    "REPOSITORY_PROMPTS",
    "marked_path",
    "prompts_root",
    "resolve_marked_path",
]
