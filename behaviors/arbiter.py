"""Arbitration: many proposals in, one velocity command out.

Two schemes, chosen per task stage:
- "priority": the highest priority level with an active proposal wins; proposals that share
  that level are blended by weighted sum (subsumption with blending among equals);
- "weighted": every active proposal is blended, weights = behaviour urgency x layer gain.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

from behaviors.proposal import Behaviour, Proposal, clamp

ArbiterMode = Literal["priority", "weighted"]


@dataclass(frozen=True, slots=True)
class Layer:
    """One behaviour instance in a task stage, with its arbitration priority and gain."""

    behaviour: Behaviour
    priority: int = 0
    gain: float = 1.0


@dataclass(frozen=True, slots=True)
class Command:
    vx_mps: float
    vyaw_radps: float


STOP = Command(0.0, 0.0)


class Arbiter:
    """Combines one proposal per layer into one command. Holds no per-tick state."""

    __slots__ = ("_gains", "_max_speed_mps", "_max_turn_radps", "_mode", "_priorities")

    def __init__(
        self,
        layers: Sequence[Layer],
        mode: ArbiterMode = "priority",
        max_speed_mps: float = 0.5,
        max_turn_radps: float = 1.2,
    ) -> None:
        if mode not in ("priority", "weighted"):
            raise ValueError(f"unknown arbiter mode {mode!r}: expected 'priority' or 'weighted'")
        self._mode = mode
        self._priorities = tuple(layer.priority for layer in layers)
        self._gains = tuple(layer.gain for layer in layers)
        self._max_speed_mps = max_speed_mps
        self._max_turn_radps = max_turn_radps

    def combine(self, proposals: Sequence[Proposal]) -> tuple[float, float]:
        """Return (vx_mps, vyaw_radps); (0, 0) when no proposal is active."""
        priorities = self._priorities
        gains = self._gains
        if len(proposals) != len(priorities):
            raise ValueError(f"expected {len(priorities)} proposals, got {len(proposals)}")
        level = None
        if self._mode == "priority":
            for i, p in enumerate(proposals):
                if p.active and (level is None or priorities[i] > level):
                    level = priorities[i]
            if level is None:
                return 0.0, 0.0
        total = vx = vyaw = 0.0
        for i, p in enumerate(proposals):
            if not p.active or (level is not None and priorities[i] != level):
                continue
            w = p.weight * gains[i]
            if w <= 0.0:
                continue
            total += w
            vx += w * p.vx_mps
            vyaw += w * p.vyaw_radps
        if total <= 0.0:
            # Active proposals with zero weight still mean "stand still" at that level.
            return 0.0, 0.0
        return (
            clamp(vx / total, self._max_speed_mps),
            clamp(vyaw / total, self._max_turn_radps),
        )
