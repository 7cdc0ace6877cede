"""``still``: the neutral face (the renderer adds lip-sync while the robot speaks)."""

from __future__ import annotations

from chameleons.worker.behaviours.base import NO_INPUT, Behaviour
from chameleons.worker.behaviours.registry import register_behaviour
from chameleons.worker.frames import F32Array


@register_behaviour("still")
class StillBehaviour(Behaviour):
    def sample(self, t: float, out: F32Array) -> float:
        out[:] = self.context.neutral
        return NO_INPUT
