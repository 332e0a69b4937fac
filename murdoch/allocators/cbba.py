"""CBBA (Choi, Brunet & How 2009) on the robots: consensus on single-robot tasks."""

from __future__ import annotations

from murdoch.allocators.base import Allocator, RobotHooks, UserHooks
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport
from murdoch.wire import Codec


def robot_member(transport: Transport, clock: Clock, hooks: RobotHooks) -> TeamMember:
    from murdoch.allocators.consensus_robot import ConsensusRobot

    return ConsensusRobot(transport, clock, hooks, "cbba")


def user_member(transport: Transport, clock: Clock, hooks: UserHooks) -> TeamMember:
    from murdoch.allocators.consensus_user import ConsensusUser

    return ConsensusUser(transport, clock, hooks)


def codec() -> Codec:
    from murdoch.allocators.team_messages import TEAM_CODEC

    return TEAM_CODEC


CBBA = Allocator("cbba", "consensus-based bundles: each robot plans a path of tasks",
                 codec, robot_member, user_member, sub_tasks=False)
