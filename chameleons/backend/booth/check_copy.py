"""What the booth check can judge of a ``copy`` condition's parameters (issue 31).

The check runs the chosen condition with its full parameters (:mod:`.check_run`) while the
technician turns, nods (and, when the condition copies the head but not the brows or the
reverse, raises the eyebrows). From what the worker reports it judges:

- **the delay**: fixed, against the configured value (``MAX_DELAY_ERROR_S``); a
  distribution, within its range (uniform: ``[low, high]``; normal: mean +- 3 SD, cut to
  0..11.5 s) widened by the same tolerance; ``coexpress``: about 0 s;
- **the channels**: the head yaw must be copied when the condition copies it (``channels``
  with ``HeadYaw``, or ``only: [shakes]``); a condition that does not copy the head turn
  cannot be judged from it (a warning, not a pass). When the brows moved (the worker's
  ``movement_brows``: peak-to-peak brow raise in and out), brows not copied must stay at
  neutral and brows copied must move;
- **intermittent**: the robot copies in bouts, so the movement may fall into a rest: only a
  copied bout is judged (no copy measured is a warning saying so);
- ``only``: the step says what is copied (the named expressions);
- **the gain**: the robot's head turn over the participant's (the probe's least-squares
  slope of the sent yaw on the captured yaw at the measured delay) against the condition's
  gain on ``HeadYaw``, within ``GAIN_TOLERANCE`` of it (relative); when the brows are copied
  and were raised, the robot's brow raise over the participant's against the brows' gain
  too (not with ``only`` or ``intermittent``, whose gating cuts the raise, nor when the
  gained raise would pass the blendshapes' ceiling of 1). Every condition is judged on it:
  a gain of 1 must copy at the participant's amplitude.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from chameleons.worker.behaviours.copy_params import (
    EXPRESSIONS,
    GROUPS,
    MAX_DELAY,
    expand,
    nominal_delay,
)

MAX_DELAY_ERROR_S = 0.25  # measured against the configured copy delay
BROWS_MOVED = 0.2  # the participant's brow raise (0..1, peak to peak) that counts as raised
BROWS_STILL = 0.05  # the robot's brows moved less than this: left at neutral
BROWS = frozenset(GROUPS["brows"])
# The probe's brow figure is the largest of these (chameleons/worker/recorder_stage.py).
BROW_RAISES = ("browInnerUp", "browOuterUpLeft", "browOuterUpRight")
GAIN_TOLERANCE = 0.2  # measured gain within +-20 % of the configured one
BROW_CEILING = 0.95  # a gained raise above this is cut at 1: its ratio is not the gain


def delay_range(params: Mapping[str, Any]) -> tuple[float, float]:
    """The delays the condition may run at (one value twice when fixed)."""
    if params.get("coexpress"):
        return 0.0, 0.0
    delay = params.get("delay")
    if isinstance(delay, Mapping) and "uniform" in delay:
        low, high = delay["uniform"]
        return float(low), float(high)
    if isinstance(delay, Mapping):
        mean, sd = float(delay["normal"]["mean"]), float(delay["normal"]["sd"])
        return max(0.0, mean - 3 * sd), min(MAX_DELAY, mean + 3 * sd)
    fixed = nominal_delay(params)
    return fixed, fixed


def copied(params: Mapping[str, Any]) -> frozenset[str]:
    """The channels the condition copies (``only``: its expressions' channels)."""
    if params.get("only"):
        return frozenset(c for e in params["only"] for c in EXPRESSIONS[e].channels)
    channels = params.get("channels", "all")
    return frozenset(expand([channels] if isinstance(channels, str) else list(channels)))


def copies_head_turn(params: Mapping[str, Any]) -> bool:
    return "HeadYaw" in copied(params)


def separates_brows(params: Mapping[str, Any]) -> bool:
    """Whether the condition copies the head turn and not the brows, or the reverse: the
    check then asks for a brow raise too."""
    brows = bool(copied(params) & BROWS)
    return copies_head_turn(params) != brows


def judge_delay(params: Mapping[str, Any], measured: float) -> tuple[bool, str]:
    """Whether ``measured`` fits the condition's delay, and the words for it."""
    low, high = delay_range(params)
    tol = MAX_DELAY_ERROR_S
    if low == high:
        off = measured - low
        words = (f"{measured:.2f} s measured movement to movement ({off * 1000:+.0f} ms; "
                 f"allowed ±{tol * 1000:.0f} ms)")  # fmt: skip
        return abs(off) <= tol, words
    fits = low - tol <= measured <= high + tol
    return fits, (f"{measured:.2f} s measured movement to movement (allowed "
                  f"{low:.2f}-{high:.2f} s ±{tol * 1000:.0f} ms: the delay is drawn)")  # fmt: skip


def judge_brows(params: Mapping[str, Any], brows: Mapping[str, Any] | None) -> tuple[str, str]:
    """``(status, words)`` for the brows: ``pass``/``fail`` when the brows were raised and the
    condition says whether they are copied, ``""`` when there is nothing to judge."""
    if not separates_brows(params):
        return "", ""
    raised = _number((brows or {}).get("captured"))
    sent = _number((brows or {}).get("sent"))
    if raised is None or sent is None or raised < BROWS_MOVED:
        return "", "brows not judged (no brow raise seen)"
    if copied(params) & BROWS:
        ok = sent >= BROWS_STILL
        return ("pass" if ok else "fail"), (
            f"brows copied (raise {raised:.2f}, robot {sent:.2f})" if ok
            else f"the brows were raised ({raised:.2f}) but the robot's did not move")  # fmt: skip
    ok = sent < BROWS_STILL
    return ("pass" if ok else "fail"), (
        f"brows not copied, as configured (raise {raised:.2f}, robot {sent:.2f})" if ok
        else f"the brows were copied (raise {raised:.2f}, robot {sent:.2f}) but the "
        "condition does not copy them")  # fmt: skip


def gain_of(params: Mapping[str, Any], channel: str) -> float:
    """The condition's gain on ``channel`` (a number for all, or a mapping whose later keys
    win, as the copy behaviour applies them; absent: 1)."""
    gain = params.get("gain", 1.0)
    if not isinstance(gain, Mapping):
        return float(gain)
    value = 1.0
    for key, number in gain.items():
        if channel in expand([key]):
            value = float(number)
    return value


def judge_gain(params: Mapping[str, Any], probe: Mapping[str, Any] | None,
               brows: Mapping[str, Any] | None) -> tuple[str, str]:  # fmt: skip
    """``(status, words)`` for the gain realised on the head turn (the probe's ``gain``)
    and, where they can show it, on the brows; ``""`` status when nothing was judged."""
    parts: list[tuple[bool, str]] = []
    measured = _number((probe or {}).get("gain"))
    if copies_head_turn(params) and measured is not None:
        parts.append(_gain_part("head turn", gain_of(params, "HeadYaw"), measured))
    raised, sent = _number((brows or {}).get("captured")), _number((brows or {}).get("sent"))
    gains = {gain_of(params, name) for name in BROW_RAISES}
    plain = not params.get("only") and not params.get("intermittent")
    if (plain and set(BROW_RAISES) <= copied(params) and len(gains) == 1
            and raised is not None and sent is not None and raised >= BROWS_MOVED):  # fmt: skip
        (gain,) = gains
        if raised * gain <= BROW_CEILING:
            parts.append(_gain_part("brow raise", gain, sent / raised))
    if not parts:
        return "", ""
    status = "pass" if all(ok for ok, _ in parts) else "fail"
    return status, "; ".join(words for _, words in parts)


def _gain_part(what: str, configured: float, measured: float) -> tuple[bool, str]:
    low, high = configured * (1 - GAIN_TOLERANCE), configured * (1 + GAIN_TOLERANCE)
    ok = low <= measured <= high if configured > 0 else measured < 0.05
    allowed = f"allowed {low:.2f}-{high:.2f}" if configured > 0 else "allowed below 0.05"
    ratio = f"the robot's was {measured:.2f} times the participant's"
    if ok:
        return True, f"gain {configured:g} realised on the {what}: {ratio} ({allowed})"
    return False, (f"gain NOT realised on the {what}: {ratio}, the condition's gain is "
                   f"{configured:g} ({allowed})")  # fmt: skip


def what_is_copied(params: Mapping[str, Any]) -> str:
    """A note for the step when the condition copies only some expressions or in bouts."""
    notes = []
    if params.get("only"):
        notes.append("copies only " + ", ".join(EXPRESSIONS[e].words for e in params["only"]))
    if params.get("intermittent"):
        notes.append("copies in bouts: only a copied bout is judged")
    return "; ".join(notes)


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
