"""Pushing with the bumpers."""

from __future__ import annotations

from dataclasses import dataclass

from behaviors.basis.speed_limits import ReversibleSpeedLimit
from behaviors.proposal import INACTIVE, Proposal
from behaviors.snapshot import Snapshot


@dataclass(frozen=True, slots=True)
class PushWithBumpers(ReversibleSpeedLimit):
    """While a front bumper is pressed, drive straight ahead ("contact"); "blocked" when stalled.

    A stall while in contact means the object will not move further (e.g. it is against a
    wall), which the cleanup task takes as "pushed to the edge". A negative speed backs away
    from whatever was bumped instead (to get room to manoeuvre).
    """

    speed_mps: float = 0.25
    max_age_s: float = 0.5
    weight: float = 0.8
    name: str = "push-with-bumpers"
    max_turn_radps: float = 0.0

    def inputs_key(self, snapshot: Snapshot, now: float) -> int:
        """0 no fresh front contact, 1 in contact, 2 in contact and stalled (see `runner`)."""
        bumpers = snapshot.bumpers
        if bumpers is None or now - bumpers.time_s > self.max_age_s or not bumpers.front_pressed:
            return 0
        odo = snapshot.odometry
        return 2 if odo is not None and odo.stall and now - odo.time_s <= self.max_age_s else 1

    def decide(self, snapshot: Snapshot, now: float) -> Proposal:
        contact = self.inputs_key(snapshot, now)
        if contact == 0:
            return INACTIVE
        signal = "blocked" if contact == 2 else "contact"
        return Proposal(True, self.speed_mps, 0.0, self.weight, signal, 0.0)
