"""Whether a language's prompts can run a session: checked before the session starts,
never found out in the middle of it.

A session in a language other than an actor's main one plays that actor's prompts in
``prompts/<lang>/<actor>/`` only (:mod:`chameleons.prompts.languages`). When that catalogue
lacks prompts the study can need (or recordings the main language has), a wizard would
have nothing to play at some point, and a Wizard-of-Oz wizard must never word a prompt
himself. So a real session in such a language is refused when it is registered, when it
starts (the phone may have changed the language) and when the phone asks for it; a
rehearsal is let through with the same sentence as a warning (a lab tries a language out
before it is recorded). The PI's study list and ``chameleons rehearse`` show the gaps of
every language the study declares.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from chameleons.backend.sessions.flow import Flow
from chameleons.backend.studies.errors import ConflictError
from chameleons.backend.wizard.catalogues import MissingCatalogueError, catalogue_for
from chameleons.experiment.model import Study
from chameleons.prompts import Catalogue
from chameleons.prompts.languages import LanguageGap, language_gap, study_needs
from chameleons.prompts.locations import prompts_root
from chameleons.prompts.manifest import ACTOR_PROFILE_NAME
from chameleons.prompts.profile import load_profile


def language_gaps(
    state: Any, spec: Study, language: str, actors: Iterable[str] | None = None
) -> list[LanguageGap]:
    """The gaps of ``language`` for ``actors`` (default: the study's), in the groups the
    study can need; empty when every actor can run a session in it."""
    needed = study_needs({t.id: {i.id for i in t.items} for t in spec.tasks}, spec.robot_names)
    chosen = [actor.id for actor in spec.actors] if actors is None else actors
    gaps = []
    for actor in dict.fromkeys(chosen):
        if _main_language(state, actor) in (None, language):
            continue  # no catalogue at all (the console says so), or its own language
        try:
            base = catalogue_for(state, actor)
            translated = catalogue_for(state, actor, language)
        except MissingCatalogueError:
            continue
        gap = language_gap(base, translated, language, needed)
        if not gap.complete:
            gaps.append(gap)
    return gaps


def gaps_sentence(gaps: list[LanguageGap], language: str) -> str:
    return (
        f"The prompt catalogue in {language} is incomplete: "
        + "; ".join(gap.sentence() for gap in gaps)
        + f". Record or synthesise them (prompts/README.md, Languages) before running "
        f"sessions in {language}."
    )


def study_warnings(state: Any, spec: Study) -> dict[str, str]:
    """language -> why its prompts cannot run a session, for each declared language."""
    found = {language: language_gaps(state, spec, language) for language in spec.languages}
    return {language: gaps_sentence(gaps, language) for language, gaps in found.items() if gaps}


def require_prompts(state: Any, flow: Flow, language: str | None = None) -> str | None:
    """Refuse a real session whose language (or ``language``, the one it is about to get)
    cannot voice the session's actors; for a rehearsal, the warning sentence instead."""
    wanted = language or flow.session.language
    actors = [interaction.actor for interaction in flow.interactions]
    gaps = language_gaps(state, flow.spec, wanted, actors)
    if not gaps:
        return None
    sentence = gaps_sentence(gaps, wanted)
    if flow.session.is_rehearsal:
        return sentence
    raise ConflictError(
        f"{sentence} A real session in {wanted} cannot run: a wizard would have no prompt "
        f"to play. Register the participant in another language."
    )


def _main_language(state: Any, actor: str) -> str | None:
    """The language of ``prompts/<actor>/`` (its ``actor.yaml``), None without it; read from
    a catalogue already loaded, else from the profile alone (cheap: no manifest read)."""
    for cache in ("prompt_catalogues", "wizard_catalogues"):
        loaded: dict[str, Catalogue] | None = getattr(state, cache, None)
        if loaded is not None and actor in loaded:
            return loaded[actor].profile.language
    directory: Path = prompts_root(state.settings) / actor
    if not directory.is_dir():
        return None
    profile, _problems = load_profile(directory / ACTOR_PROFILE_NAME, actor)
    return profile.language
