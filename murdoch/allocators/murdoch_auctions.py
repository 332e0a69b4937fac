"""MURDOCH (`murdoch.node.Node`) as an allocator: auctions over the bus."""

from __future__ import annotations

import random

from murdoch.allocators.base import Allocator, Assignment, RobotHooks, UserHooks
from murdoch.auction.bidder import Contract
from murdoch.auction.messages import AUCTION_CODEC, Announce
from murdoch.member import TeamMember
from murdoch.node import Node
from murdoch.transport import Clock, Transport
from murdoch.user_agent import RandomizedBackoff


def _assignment(contract: Contract) -> Assignment:
    a = contract.announce
    return Assignment(a.task_id, a.name, a.params)


def robot_member(transport: Transport, clock: Clock, hooks: RobotHooks) -> TeamMember:
    def metric(announce: Announce) -> float | None:
        return hooks.score(announce.name, announce.params, announce.task_id)

    def on_start(contract: Contract) -> None:
        hooks.on_start(_assignment(contract))

    def on_stop(contract: Contract, reason: str) -> None:
        hooks.on_stop(_assignment(contract), reason)

    backoff = hooks.backoff or RandomizedBackoff(random.Random(hooks.agent_id), base_s=2.0,
                                                 cap_s=10.0)
    return Node(transport, clock, agent_id=hooks.agent_id, subjects=hooks.subjects,
                metric=metric, on_start=on_start, on_stop=on_stop,
                on_outcome=hooks.on_outcome, observer=hooks.observer, backoff=backoff)


def user_member(transport: Transport, clock: Clock, hooks: UserHooks) -> TeamMember:
    return Node(transport, clock, agent_id=hooks.agent_id, observer=hooks.observer,
                backoff=hooks.backoff)


MURDOCH = Allocator("murdoch", "auctions: each task to the best idle bidder, one at a time",
                    lambda: AUCTION_CODEC, robot_member, user_member, sub_tasks=True)
