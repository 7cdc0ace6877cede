"""The prompt catalogue: per-actor manifests of pre-recorded robot prompts.

Pure Python and file reads only, so both the server (wizard console) and the worker
(playback) import it. Format: ``prompts/README.md``.
"""

from chameleons.prompts.catalogue import Catalogue, pick_variant
from chameleons.prompts.loader import (
    CatalogueError,
    actor_directories,
    load_catalogue,
    load_catalogues,
)
from chameleons.prompts.manifest import MANIFEST_COLUMNS, manifest_text, write_manifest
from chameleons.prompts.model import (
    ActorProfile,
    Prompt,
    PromptGroup,
    Stage,
    SuggestionKind,
    estimate_duration,
    item_ref,
)

__all__ = [
    "MANIFEST_COLUMNS",
    "ActorProfile",
    "Catalogue",
    "CatalogueError",
    "Prompt",
    "PromptGroup",
    "Stage",
    "SuggestionKind",
    "actor_directories",
    "estimate_duration",
    "item_ref",
    "load_catalogue",
    "load_catalogues",
    "manifest_text",
    "pick_variant",
    "write_manifest",
]
