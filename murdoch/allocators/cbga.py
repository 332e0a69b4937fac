"""CBGA (Hunt, Meng, Hinde & Huang 2014) on the robots: consensus with equipment.

A robot's devices (its resource subjects: camera, laser, bumper, gripper, overhead-camera,
mobile ...) are its equipment, and a task's required subjects the equipment it needs."""

from __future__ import annotations

from murdoch.allocators.base import Allocator, RobotHooks
from murdoch.allocators.consensus_robot import ConsensusRobot
from murdoch.allocators.consensus_user import ConsensusUser
from murdoch.allocators.team_messages import TEAM_CODEC
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport


def robot_member(transport: Transport, clock: Clock, hooks: RobotHooks) -> TeamMember:
    return ConsensusRobot(transport, clock, hooks, "cbga")


CBGA = Allocator("cbga", "consensus-based grouping: bundles with equipment and groups",
                 TEAM_CODEC, robot_member, ConsensusUser, sub_tasks=False)
