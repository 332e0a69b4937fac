"""CBBA (Choi, Brunet & How 2009) on the robots: consensus on single-robot tasks."""

from __future__ import annotations

from murdoch.allocators.base import Allocator, RobotHooks
from murdoch.allocators.consensus_robot import ConsensusRobot
from murdoch.allocators.consensus_user import ConsensusUser
from murdoch.allocators.team_messages import TEAM_CODEC
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport


def robot_member(transport: Transport, clock: Clock, hooks: RobotHooks) -> TeamMember:
    return ConsensusRobot(transport, clock, hooks, "cbba")


CBBA = Allocator("cbba", "consensus-based bundles: each robot plans a path of tasks",
                 TEAM_CODEC, robot_member, ConsensusUser, sub_tasks=False)
