"""What ``copy`` (and ``yoked_copy``) may be told: which channels, how much, how often, when.

Plain Python, no behaviour built: the study loader checks a condition's ``params`` with the
same :class:`~chameleons.worker.behaviours.params.Param` declarations the worker uses, and the
server describes what ran (:func:`settings_of`, :func:`in_words`) for the export and the
console. docs/design-space.md explains each parameter and why.

- ``channels``: ``all`` (default), ``head``, ``face`` (every blendshape and the eye
  rotations: all but the head), ``eyes``, ``brows``, ``mouth``, or a list of those groups,
  ARKit blendshape names (``mouthSmileLeft``) and head axes (``HeadYaw``/``HeadPitch``/
  ``HeadRoll``). Channels not copied stay at the robot's neutral; the robot's lip-sync
  owns the mouth and jaw while it speaks, whatever is copied.
- ``gain``: a number (0..3) scaling every copied channel's deviation from neutral, or a
  mapping from groups/channel names to numbers (unnamed channels: 1).
- ``mirror``: true (copy as a mirror image), false (the same side) or absent (the booth's
  ``mirror`` setting).
- ``delay``: seconds, or ``{uniform: [low, high]}`` or ``{normal: {mean: m, sd: s}}``
  (truncated to 0..max): a jittered copy. A new delay is drawn at every bout start with
  ``intermittent``, else every ``delay_resample_s`` seconds (default 10), crossfaded over
  0.3 s. Draws are seeded (``seed``).
- ``coexpress``: true: zero lag (the robot expresses with the participant, as fast as the
  pipeline allows); no anticipation is claimed. Excludes ``delay``.
- ``intermittent``: ``{rate_per_s, bout_s, rest}``: copying in bouts of ``bout_s`` seconds
  whose onsets follow a Poisson process at ``rate_per_s`` while resting (rest lengths are
  exponential, mean ``1 / rate_per_s``); during rests the copied channels are at neutral
  (``rest: neutral``) or show the synthetic face's idle motion (``rest: natural``).
- ``only``: congruent-only copying of named expressions (:data:`EXPRESSIONS`): their
  channels are copied while their trigger is above its threshold, the rest stays neutral.
- ``seed``: the random draws' seed; absent: the server uses the interaction's id.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from chameleons.worker.frames import BLENDSHAPE_NAMES, EYE_NAMES, HEAD_NAMES, canonical_name

CHANNEL_NAMES: tuple[str, ...] = (*BLENDSHAPE_NAMES, *HEAD_NAMES, *EYE_NAMES)
CHANNEL_INDEX = {name: i for i, name in enumerate(CHANNEL_NAMES)}
_EYE_BLENDSHAPES = tuple(n for n in BLENDSHAPE_NAMES if n.startswith("eye"))
GROUPS: dict[str, tuple[str, ...]] = {
    "all": CHANNEL_NAMES,
    "head": HEAD_NAMES,
    "face": (*BLENDSHAPE_NAMES, *EYE_NAMES),
    "eyes": (*_EYE_BLENDSHAPES, *EYE_NAMES),
    "brows": tuple(n for n in BLENDSHAPE_NAMES if n.startswith("brow")),
    "mouth": tuple(n for n in BLENDSHAPE_NAMES if n.startswith(("mouth", "jaw", "tongue"))),
}
MAX_GAIN = 3.0
MAX_DELAY = 11.5  # 12 s of history, half a second of slack to interpolate
DEFAULT_DELAY = 4.0
MIN_BOUT = 0.2  # a bout ramps in and out over 0.1 s each
REST_MODES = ("neutral", "natural")


@dataclass(frozen=True)
class Expression:
    """A named expression for ``only``: the channels copied while ``trigger`` (the largest
    absolute value of its channels, head axes in degrees re-centred) is >= ``threshold``."""

    channels: tuple[str, ...]
    trigger: tuple[str, ...]
    threshold: float
    words: str


EXPRESSIONS: dict[str, Expression] = {
    "smiles": Expression(("mouthSmileLeft", "mouthSmileRight", "cheekSquintLeft",
                          "cheekSquintRight"), ("mouthSmileLeft", "mouthSmileRight"), 0.3,
                         "smiles (mouthSmile >= 0.3)"),
    "nods": Expression(("HeadPitch",), ("HeadPitch",), 5.0, "nods (head pitch >= 5 deg)"),
    "shakes": Expression(("HeadYaw",), ("HeadYaw",), 10.0, "head shakes (yaw >= 10 deg)"),
    "tilts": Expression(("HeadRoll",), ("HeadRoll",), 8.0, "head tilts (roll >= 8 deg)"),
    "brow_raises": Expression(GROUPS["brows"], ("browInnerUp", "browOuterUpLeft",
                                                "browOuterUpRight"), 0.3,
                              "brow raises (browUp >= 0.3)"),
    "frowns": Expression(("browDownLeft", "browDownRight", "mouthFrownLeft", "mouthFrownRight"),
                         ("browDownLeft", "browDownRight"), 0.3, "frowns (browDown >= 0.3)"),
}  # fmt: skip


def channel_name(raw: object) -> str | None:
    """A group name, a head/eye axis or a canonical ARKit name, or None."""
    if not isinstance(raw, str):
        return None
    if raw in GROUPS or raw in CHANNEL_INDEX:
        return raw
    return canonical_name(raw)


def expand(names: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """Groups and channel names -> the channel names, in vector order."""
    chosen: set[str] = set()
    for name in names:
        chosen.update(GROUPS.get(name, (name,)))
    return tuple(n for n in CHANNEL_NAMES if n in chosen)


def check_channels(value: object) -> tuple[Any, str | None]:
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not items:
        return None, f"must be {_CHANNELS_SHAPE}, got {value!r}"
    names: list[str] = []
    for item in items:
        name = channel_name(item)
        if name is None:
            return None, f"{item!r} is not a channel: use {_CHANNELS_SHAPE}"
        if name not in names:
            names.append(name)
    return (names[0] if isinstance(value, str) else names), None


def check_gain(value: object) -> tuple[Any, str | None]:
    if isinstance(value, Mapping):
        gains: dict[str, float] = {}
        for key, number in value.items():
            name = channel_name(key)
            if name is None:
                return None, f"{key!r} is not a channel (a group, ARKit name or head axis)"
            if _bad_number(number, 0.0, MAX_GAIN):
                return None, f"the gain of {key} must be in 0..{MAX_GAIN:g}, got {number!r}"
            gains[name] = float(number)
        if not gains:
            return None, "must name at least one channel"
        return gains, None
    if _bad_number(value, 0.0, MAX_GAIN):
        return None, (
            f"must be a number in 0..{MAX_GAIN:g} or a mapping channel: gain, got {value!r}"
        )
    return float(value), None  # type: ignore[arg-type]


def check_delay(value: object) -> tuple[Any, str | None]:
    """Seconds, ``{uniform: [low, high]}`` or ``{normal: {mean, sd}}``."""
    if not isinstance(value, Mapping):
        if _bad_number(value, 0.0, MAX_DELAY):
            return None, f"must be {_DELAY_SHAPE}, got {value!r}"
        return float(value), None  # type: ignore[arg-type]
    if len(value) != 1:
        return None, f"must be {_DELAY_SHAPE} (one distribution), got {dict(value)!r}"
    ((kind, body),) = value.items()
    if kind == "uniform":
        if (
            not isinstance(body, list)
            or len(body) != 2
            or any(_bad_number(v, 0.0, MAX_DELAY) for v in body)
            or body[0] > body[1]
        ):
            return None, (
                f"uniform must be [low, high] seconds within 0..{MAX_DELAY:g}, got {body!r}"
            )
        return {"uniform": [float(body[0]), float(body[1])]}, None
    if kind == "normal":
        if (
            not isinstance(body, Mapping)
            or set(body) != {"mean", "sd"}
            or _bad_number(body["mean"], 0.0, MAX_DELAY)
            or _bad_number(body["sd"], 0.0, 5.0)
        ):
            return None, (f"normal must be {{mean: seconds in 0..{MAX_DELAY:g}, sd: seconds "
                          f"in 0..5}}, got {body!r}")  # fmt: skip
        return {"normal": {"mean": float(body["mean"]), "sd": float(body["sd"])}}, None
    return None, f"must be {_DELAY_SHAPE}; {kind!r} is not a distribution"


def check_intermittent(value: object) -> tuple[Any, str | None]:
    shape = (
        f"{{rate_per_s: bouts per second, bout_s: seconds >= {MIN_BOUT}, rest: neutral|natural}}"
    )
    if (
        not isinstance(value, Mapping)
        or not {"rate_per_s", "bout_s"} <= set(value)
        or not set(value) <= {"rate_per_s", "bout_s", "rest"}
    ):
        return None, f"must be {shape}, got {value!r}"
    if _bad_number(value["rate_per_s"], 0.0, 10.0) or value["rate_per_s"] <= 0:
        return None, f"rate_per_s must be a number in 0..10 above 0, got {value['rate_per_s']!r}"
    if _bad_number(value["bout_s"], MIN_BOUT, 600.0):
        return None, f"bout_s must be seconds in {MIN_BOUT}..600, got {value['bout_s']!r}"
    rest = value.get("rest", "neutral")
    if rest not in REST_MODES:
        return None, f"rest must be neutral or natural, got {rest!r}"
    return {"rate_per_s": float(value["rate_per_s"]), "bout_s": float(value["bout_s"]),
            "rest": rest}, None  # fmt: skip


def check_only(value: object) -> tuple[Any, str | None]:
    items = [value] if isinstance(value, str) else value
    known = ", ".join(EXPRESSIONS)
    if not isinstance(items, list) or not items:
        return None, f"must be a list of expressions ({known}), got {value!r}"
    for item in items:
        if item not in EXPRESSIONS:
            return None, f"{item!r} is not a named expression ({known})"
    return list(dict.fromkeys(items)), None


def check_together(values: dict[str, Any], given: Mapping[str, Any]) -> list[tuple[str, str]]:
    """Problems of the combination; a ``coexpress`` copy's delay is settled to 0 here."""
    problems = []
    if values.get("coexpress"):
        if "delay" in given and given["delay"] != 0:
            problems.append(("coexpress", "means zero lag: leave delay out (or coexpress false)"))
        values["delay"] = 0.0
    if "only" in given and "channels" in given and values.get("channels") != "all":
        problems.append(("only", "copies its expressions' own channels: leave channels out"))
    if "delay_resample_s" in given and not isinstance(values.get("delay"), dict):
        problems.append(("delay_resample_s", "only applies to a delay distribution"))
    return problems


def _bad_number(value: object, low: float, high: float) -> bool:
    return (isinstance(value, bool) or not isinstance(value, int | float)
            or not math.isfinite(value) or not low <= value <= high)  # fmt: skip


_CHANNELS_SHAPE = (f"one of {', '.join(GROUPS)} or a list of those, ARKit names and head axes "
                   "(HeadYaw, HeadPitch, HeadRoll)")  # fmt: skip
_DELAY_SHAPE = (f"a number of seconds in 0..{MAX_DELAY:g} or a distribution ({{uniform: "
                "[low, high]} or {normal: {mean: m, sd: s}})")  # fmt: skip


def settings_of(params: Mapping[str, Any]) -> dict[str, Any]:
    """Every copy setting made explicit (what absent means filled in), for the record."""
    coexpress = bool(params.get("coexpress", False))
    return {
        "channels": params.get("channels", "all"),
        "gain": params.get("gain", 1.0),
        "mirror": params.get("mirror"),
        "delay": 0.0 if coexpress else params.get("delay", DEFAULT_DELAY),
        "delay_resample_s": params.get("delay_resample_s", 10.0),
        "coexpress": coexpress,
        "intermittent": params.get("intermittent"),
        "only": params.get("only"),
        "seed": params.get("seed"),
    }


def in_words(params: Mapping[str, Any], booth_mirror: bool | None = None) -> str:
    """One line a wizard and a reader of the export understand: what is copied, how much,
    when and how often."""
    s = settings_of(params)
    if s["only"]:
        what = "only " + ", ".join(EXPRESSIONS[e].words for e in s["only"])
    else:
        channels = s["channels"]
        what = f"{channels}" if isinstance(channels, str) else ", ".join(channels)
        what = "everything" if what == "all" else what
    parts = [f"copies {what}"]
    delay = s["delay"]
    if s["coexpress"]:
        parts.append("at zero lag (co-expression)")
    elif isinstance(delay, dict) and "uniform" in delay:
        low, high = delay["uniform"]
        parts.append(f"{low:g}-{high:g} s late (uniform, redrawn {_redraw(s)})")
    elif isinstance(delay, dict):
        normal = delay["normal"]
        parts.append(f"{normal['mean']:g} s (sd {normal['sd']:g}) late (redrawn {_redraw(s)})")
    else:
        parts.append(f"{float(delay):g} s late")
    gain = s["gain"]
    if isinstance(gain, dict):
        parts.append("gain " + ", ".join(f"{k} x{v:g}" for k, v in gain.items()))
    elif gain != 1.0:
        parts.append(f"gain x{gain:g}")
    mirror = s["mirror"] if s["mirror"] is not None else booth_mirror
    if mirror is not None:
        parts.append("mirror image" if mirror else "same side")
    if s["intermittent"]:
        i = s["intermittent"]
        parts.append(f"in {i['bout_s']:g} s bouts at {i['rate_per_s']:g}/s, rest {i['rest']}")
    if s["seed"] is not None and (s["intermittent"] or isinstance(delay, dict)):
        parts.append(f"seed {s['seed']}")
    return ", ".join(parts)


def _redraw(s: Mapping[str, Any]) -> str:
    return "per bout" if s["intermittent"] else f"every {s['delay_resample_s']:g} s"


def needs_seed(params: Mapping[str, Any]) -> bool:
    """Whether the copy draws random numbers (a jittered delay or bouts)."""
    return isinstance(params.get("delay"), dict) or bool(params.get("intermittent"))


def nominal_delay(params: Mapping[str, Any]) -> float:
    """The copy's delay as one number: fixed, the mean of a distribution, 0 for coexpress
    (the booth check's movement delay, the synchrony analysis' expected lag)."""
    if params.get("coexpress"):
        return 0.0
    delay = params.get("delay", DEFAULT_DELAY)
    if isinstance(delay, Mapping):
        if "uniform" in delay:
            return (float(delay["uniform"][0]) + float(delay["uniform"][1])) / 2
        return float(delay["normal"]["mean"])
    return float(delay)
