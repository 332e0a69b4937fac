"""The member task of a group watch: one of two robots watching an object from two sides.

The runner's group coordinator (`experiments.group_coordinator`) hands each member a spot
beside the object; the robot drives there, turns until the object is straight ahead in its
camera, and holds. Whether the two are in place together is judged from the simulation, not
here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from behaviors.arbiter import Layer
from behaviors.basis import Hold, ServoToLocation, VisualServoToColour
from behaviors.params import colour_of, number
from behaviors.plan_parts import avoid_layers, distance_progress, search
from behaviors.profile import RobotProfile
from behaviors.task import Stage, TaskPlan, signal, stage_elapsed


def build_watch_side(p: Mapping[str, object], profile: RobotProfile) -> TaskPlan:
    """One member of a group watch: drive to the spot (x, y) beside the object, turn until
    it is straight ahead, and hold there watching it for `duration_s`."""
    colour = colour_of(p["colour"])
    x, y = number(p, "x"), number(p, "y")
    duration = number(p, "duration_s")
    go = (*avoid_layers(profile, 0.35),
          Layer(ServoToLocation(x, y, tolerance_m=number(p, "tolerance_m"),
                                max_speed_mps=number(p, "speed_mps")), 1))
    face = (Layer(VisualServoToColour(colour, speed_mps=0.0, stop_range_m=math.inf,
                                      align_tolerance_rad=math.radians(10.0)), 1),
            Layer(search(profile, 0.0), 0))
    return TaskPlan(
        "watch-object-side",
        (Stage("go", go, until=signal("at-goal"), timeout_s=number(p, "go_s")),
         Stage("face", face, until=signal("reached"), timeout_s=20.0, on_timeout="next"),
         Stage("watch", (Layer(Hold(), 0),), until=stage_elapsed(duration))),
        progress=distance_progress(x, y),
    )
