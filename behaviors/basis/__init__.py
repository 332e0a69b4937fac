"""Basis behaviours: pure, parameterised low-level controllers.

Each behaviour is a frozen dataclass of parameters with `decide(snapshot, now) -> Proposal`.
None keeps state between ticks; anything that must be remembered (the pose or laser scan at
the start of a task stage) reaches them through `Snapshot.mark`.
"""

from behaviors.basis.avoid import Avoid, AvoidWithLaser, AvoidWithSonar
from behaviors.basis.boxwatch import BoxAlignmentFromLaser, GoalFromCamera
from behaviors.basis.colour import KeepDistanceToColour, ViewOfEnd, VisualServoToColour
from behaviors.basis.dock import DockAtCharger
from behaviors.basis.motion import BackOff, Cruise, CruiseOnHeading, Hold, TurnAbout
from behaviors.basis.navigate import ServoToLocation, Wander
from behaviors.basis.push import PushWithBumpers
from behaviors.basis.watch import WatchForMotionWithLaser

__all__ = [
    "Avoid",
    "AvoidWithLaser",
    "AvoidWithSonar",
    "BackOff",
    "BoxAlignmentFromLaser",
    "Cruise",
    "CruiseOnHeading",
    "DockAtCharger",
    "GoalFromCamera",
    "Hold",
    "KeepDistanceToColour",
    "PushWithBumpers",
    "ServoToLocation",
    "TurnAbout",
    "ViewOfEnd",
    "VisualServoToColour",
    "Wander",
    "WatchForMotionWithLaser",
]
