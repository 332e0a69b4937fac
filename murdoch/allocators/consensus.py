"""What CBBA and CBGA share on the robots: one allocator shape, told apart by its kind.

Both run `consensus_robot.ConsensusRobot` on the robots and `consensus_user.ConsensusUser` on
the runner, over the team messages of `team_messages`; the robot's member takes the kind
("cbba" or "cbga") and builds that algorithm's agent; the refined form
(`Allocator.refined`, `--refine`) adds the improvement phase on the robots. The parts load
on first use, so a MURDOCH team never imports the consensus package.
"""

from __future__ import annotations

from murdoch.allocators.base import Allocator, RobotHooks, UserHooks
from murdoch.member import TeamMember
from murdoch.transport import Clock, Transport
from murdoch.wire import Codec


def _codec() -> Codec:
    from murdoch.allocators.team_messages import TEAM_CODEC

    return TEAM_CODEC


def _user_member(transport: Transport, clock: Clock, hooks: UserHooks) -> TeamMember:
    from murdoch.allocators.consensus_user import ConsensusUser

    return ConsensusUser(transport, clock, hooks)


def consensus_allocator(kind: str, summary: str, refine: bool = False) -> Allocator:
    """The allocator whose robots run the consensus algorithm `kind` (with `refine`, and
    the improvement phase of `consensus_refine`)."""

    def robot_member(transport: Transport, clock: Clock, hooks: RobotHooks) -> TeamMember:
        from murdoch.allocators.consensus_robot import ConsensusRobot

        return ConsensusRobot(transport, clock, hooks, kind, refine=refine)

    def refined() -> Allocator:
        return consensus_allocator(kind, summary, refine=True)

    return Allocator(kind, summary, _codec, robot_member, _user_member, sub_tasks=False,
                     refined=None if refine else refined, refine=refine,
                     group_tasks=kind == "cbga")
