"""Robot personalities: which name and face go with which voice (actor).

The study's ``personas`` setting (see :class:`~chameleons.experiment.model.Personas`) says
whether names and faces are fixed per actor for the whole study or chosen per session, and
whether face and name genders must match the voice. Here are the pure pieces the loader and
the planner share: gender compatibility, whether the study has enough names and faces for
its setting (checked at load time, with a located message), and the seeded draws.
Everything is a pure function of the study and the seed.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Sequence
from itertools import combinations
from typing import Any

from chameleons.experiment.model import Study
from chameleons.experiment.reader import Reader


def compatible(voice: str, other: str) -> bool:
    """A face or name without a gender goes with any voice; otherwise genders must agree."""
    return not other or not voice or voice == other


def check_fits(reader: Reader, parts: dict[str, Any], name_genders: dict[str, str]) -> None:
    """Enough names and faces for the persona setting (Hall's condition per gender set)."""
    personas = parts["personas"]
    actors = [a.gender for a in parts["actors"]]
    per_session = len(parts["conditions"])
    match = personas.match_gender
    faces = [f.gender if match else "" for f in parts["faces"]]
    names = [name_genders.get(n, "") if match else "" for n in parts["robot_names"]]
    if personas.faces == "per_actor":
        _check_matching(reader, "faces", "actor", actors, faces, len(actors))
    elif match:
        _check_matching(reader, "faces", "session", actors, faces, per_session)
    if personas.names == "per_actor":
        _check_matching(reader, "robot_names", "actor", actors, names, len(actors))
    elif match:
        _check_matching(reader, "robot_names", "session", actors, names, per_session)


def _check_matching(
    reader: Reader, place: str, per: str, voices: list[str], others: list[str], group: int
) -> None:
    """Every ``group`` voices (all of them, or any session's) can get distinct compatible
    ``others``: for every set of voice genders, enough compatible ones exist."""
    genders = sorted(set(voices))
    for size in range(1, len(genders) + 1):
        for chosen in combinations(genders, size):
            needed = min(group, sum(1 for v in voices if v in chosen))
            fitting = sum(1 for o in others if any(compatible(g, o) for g in chosen))
            if fitting < needed:
                what = "one per actor" if per == "actor" else "distinct ones in a session"
                reader.problem(
                    place,
                    f"has {fitting} fitting {'/'.join(chosen)} voices, but {needed} are "
                    f"needed ({what}; personas.match_gender keeps genders apart)",
                )
                return


def per_actor(
    study: Study,
    seed: int,
    purpose: str,
    candidates: Sequence[str],
    gender_of: Callable[[str], str],
) -> dict[str, str]:
    """One distinct candidate per actor, drawn once per study and seed (the loader has
    checked that a compatible assignment exists)."""
    rng = random.Random(f"{seed}/{purpose}-of-actors")
    voices = [(a.id, a.gender if study.personas.match_gender else "") for a in study.actors]
    found = _assign(voices, list(candidates), gender_of, rng)
    if found is None:  # the loader's check makes this unreachable for loaded studies
        raise ValueError(f"no {purpose} for every actor fits personas.match_gender")
    return found


def per_session(
    study: Study,
    rng: random.Random,
    actors: Sequence[str],
    candidates: Sequence[str],
    gender_of: Callable[[str], str],
) -> list[str]:
    """Distinct candidates for a session's actors, in position order."""
    if not study.personas.match_gender:
        return rng.sample(list(candidates), len(actors))  # as plans before personas existed
    genders = {a.id: a.gender for a in study.actors}
    voices = [
        (str(p), genders[a] if study.personas.match_gender else "") for p, a in enumerate(actors)
    ]
    found = _assign(voices, list(candidates), gender_of, rng)
    if found is None:
        raise ValueError("no distinct names for this session fit personas.match_gender")
    return [found[str(p)] for p in range(len(actors))]


def _assign(
    voices: list[tuple[str, str]],
    candidates: list[str],
    gender_of: Callable[[str], str],
    rng: random.Random,
) -> dict[str, str] | None:
    """A random matching of voices to distinct compatible candidates (backtracking; the
    sets are small)."""
    order = list(candidates)
    rng.shuffle(order)
    chosen: dict[str, str] = {}

    def extend(index: int, used: set[str]) -> bool:
        if index == len(voices):
            return True
        key, gender = voices[index]
        for candidate in order:
            if candidate in used or not compatible(gender, gender_of(candidate)):
                continue
            chosen[key] = candidate
            if extend(index + 1, used | {candidate}):
                return True
        return False

    return chosen if extend(0, set()) else None
