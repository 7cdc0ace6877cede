"""Which robot the booth check runs on: the chosen condition's (its ``renderer``).

A booth whose worker drives both robots (``--driver virtual+furhat``, the ``embodiment``
template) runs a ``furhat`` condition on the Furhat and a ``2d``/``3d`` one on the display,
chosen by the ``renderer`` sent with the face (``set_face``). The check of such a condition
puts the booth on that robot the way the wizard path sets up an interaction
(:func:`chameleons.backend.wizard.robot.apply_with`): ``set_face`` with the booth's current
face (the one last acknowledged, else the face the session's interaction in that condition
has, else the study's first) and the condition's renderer. The head movement, the copy and
the test prompt then run on that robot, and the face and renderer from before are put back
at the end, whatever happens (also when the request is cancelled). Should an interaction
start during the check, it gets its own set-up instead (as for the behaviour,
:mod:`.check_run`). A worker that had no face set through the server yet started on the
display: it is put back there, with the same face id.

A ``furhat`` condition on a booth whose worker drives no Furhat is not sent at all: the
check says so in one sentence, and the steps that need the robot fail with it at once.
A condition without a ``renderer`` runs as it would in a session: on the display of a booth
with both robots (the face is sent without a renderer if the Furhat runs now), elsewhere on
the booth's robot as it is (nothing is switched). The check's result says which robot was
checked (``checked_on``).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from dataclasses import dataclass, replace
from typing import Any

from chameleons.backend.booth.check_run import set_up_started_interaction
from chameleons.backend.wizard import robot, worker_link
from chameleons.backend.wizard.health import DISPLAY, FURHAT
from chameleons.worker.control import SET_FACE
from chameleons.worker.drivers import renderers

TWO_ROBOTS = "virtual+furhat"
DISPLAY_DRIVERS = ("virtual", TWO_ROBOTS)
DISPLAY_WORDS = {"2d": "the display's 2D face", "3d": "the display's 3D head"}


@dataclass(frozen=True)
class Checked:
    """The robot a check ran on, in words, and why it could not be put on it (if so)."""

    renderer: str | None  # the renderer the check ran with (None: the booth's, unknown)
    output: str | None  # display or furhat on a booth with both robots; None otherwise
    words: str  # "the Furhat", "the display's 3D head"
    problem: str | None = None

    def describe(self) -> dict[str, Any]:
        return {"renderer": self.renderer, "output": self.output, "words": self.words,
                "problem": self.problem}  # fmt: skip


def robot_words(driver: str | None, renderer: str | None) -> str:
    """The robot a worker with ``driver`` runs a condition with ``renderer`` on."""
    if driver == FURHAT or renderer == FURHAT:  # (a booth without one: it is not checked)
        return "the Furhat"
    if driver in DISPLAY_DRIVERS:
        return DISPLAY_WORDS.get(renderer or "", "the display")
    return f"the booth's robot (driver {driver})" if driver else "the booth's robot"


def worker_driver(bridge: Any | None, booth: str) -> str | None:
    """The driver the booth's worker said hello with (None: no worker known)."""
    workers = getattr(bridge, "workers", None)
    info = workers().get(booth) if callable(workers) else None
    driver = (getattr(info, "hello", None) or {}).get("driver")
    return driver if isinstance(driver, str) and driver else None


def no_robot(condition: str | None, driver: str) -> str:
    return (f"{condition or 'this condition'} runs on the Furhat, and this booth's worker "
            f"drives no Furhat (its driver is {driver}): start it with --driver "
            "virtual+furhat (or --driver furhat) to check this condition")  # fmt: skip


@contextlib.asynccontextmanager
async def on_robot(
    state: Any, booth: str, renderer: str | None, condition: str | None, face: str | None
) -> AsyncIterator[Checked]:
    """Put ``booth`` on the robot of ``condition`` (its ``renderer``) for the block, and the
    face and renderer from before back afterwards; ``face``: the face id to use when the
    booth has none acknowledged. Yields what was checked (with a ``problem``: the block
    must not drive the robot)."""
    bridge = worker_link.bridge_of(state)
    driver = worker_driver(bridge, booth)
    previous = robot.acknowledged(bridge, booth, SET_FACE)
    current = (previous or {}).get("renderer")
    # A condition without a renderer runs on the display of a booth with both robots (the
    # set-up's face without a renderer), elsewhere on the booth's robot as it is.
    back_to_display = renderer is None and driver == TWO_ROBOTS and current == FURHAT
    chosen = renderer or (None if back_to_display or not isinstance(current, str) else current)
    output = (FURHAT if chosen == FURHAT else DISPLAY) if driver == TWO_ROBOTS else None
    checked = Checked(chosen, output, robot_words(driver, chosen))
    if renderer is None and not back_to_display:  # the booth's robot, as it is
        yield checked
        return
    if renderer == FURHAT and driver is not None and FURHAT not in renderers(driver):
        yield replace(checked, problem=no_robot(condition, driver))
        return
    face_id = (previous or {}).get("face_id") or face
    if not isinstance(face_id, str) or not face_id:
        yield replace(checked, problem="no face to set: the study names no face")
        return
    body = {"face_id": face_id, **({"renderer": renderer} if renderer else {})}
    if previous == body:  # already on it: nothing to switch or restore
        yield checked
        return
    switched = await worker_link.send_command(bridge, booth, SET_FACE, body)
    if not switched.sent:
        yield replace(checked, problem=f"the booth could not be put on {checked.words}: "
                      f"{switched.detail}")  # fmt: skip
        return
    try:
        yield checked
    finally:
        await asyncio.shield(_restore(state, booth, previous or {"face_id": face_id}))


async def _restore(state: Any, booth: str, previous: dict[str, Any]) -> None:
    """The face and renderer from before, or the set-up of an interaction that started
    during the check (its own robot)."""
    if await set_up_started_interaction(state, booth):
        return
    await worker_link.send_command(worker_link.bridge_of(state), booth, SET_FACE, previous)
