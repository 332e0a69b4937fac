"""CBGA (Hunt, Meng, Hinde & Huang 2014) on the robots: consensus with equipment.

A robot's devices (its resource subjects: camera, laser, bumper, gripper, overhead-camera,
mobile ...) are its equipment, and a task's required subjects the equipment it needs."""

from __future__ import annotations

from murdoch.allocators.base import Allocator, RobotHooks, UserHooks
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport
from murdoch.wire import Codec


def robot_member(transport: Transport, clock: Clock, hooks: RobotHooks) -> TeamMember:
    from murdoch.allocators.consensus_robot import ConsensusRobot

    return ConsensusRobot(transport, clock, hooks, "cbga")


def user_member(transport: Transport, clock: Clock, hooks: UserHooks) -> TeamMember:
    from murdoch.allocators.consensus_user import ConsensusUser

    return ConsensusUser(transport, clock, hooks)


def codec() -> Codec:
    from murdoch.allocators.team_messages import TEAM_CODEC

    return TEAM_CODEC


CBGA = Allocator("cbga", "consensus-based grouping: bundles with equipment and groups",
                 codec, robot_member, user_member, sub_tasks=False)
