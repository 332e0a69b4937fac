"""An agent on the bus: drives an auctioneer and (optionally) a bidder over a transport.

The owner calls `step()` from its own loop (a robot's control loop, a CLI loop); time comes
from the injected `clock` (simulation seconds in experiments). One subscription carries the
node's resource subjects (plus `idle` while it holds no contract, when `auto_idle`) and the
negotiation subjects its auctions and bids need, so each datagram reaches the node once.

Embedding a robot::

    node = Node(transport, clock=sim_time, subjects={"camera", "mobile"},
                metric=my_metric, on_start=start_task, on_stop=stop_task, observer=log_event)
    ...each loop: node.step()
    ...the task: node.progress(task_id, 0.4); node.complete(task_id) or node.fail(task_id, why)
    ...sub-tasks from a running task: node.announce(TaskSpec(..., parent=task_id))
    ...going to charge: node.set_subjects(())

The public methods take the node's lock, so a task thread may report while the owner's loop
steps; callbacks run inside `step()` (on the owner's thread) and must not block.
"""

from __future__ import annotations

import functools
import logging
import threading
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any, TypeVar, cast

from murdoch.auction.auctioneer import Auctioneer, RetryPlan
from murdoch.auction.bidder import Bidder, Metric, StartCallback, StopCallback
from murdoch.auction.messages import AuctionEvent, Outcome, Outgoing, TaskSpec
from murdoch.subjects import IDLE, SubjectSet, subject_set
from murdoch.transport import Clock, Transport
from murdoch.user_agent import RandomizedBackoff
from murdoch.wire import WireError

log = logging.getLogger(__name__)

OutcomeCallback = Callable[[Outcome], None]
F = TypeVar("F", bound=Callable[..., Any])


def _locked(method: F) -> F:
    @functools.wraps(method)
    def wrapper(self: Node, *args: Any, **kwargs: Any) -> Any:
        with self._lock:
            return method(self, *args, **kwargs)

    return cast(F, wrapper)


Observer = Callable[[AuctionEvent], None]


class Node:
    """MURDOCH's team member (`murdoch.member.TeamMember`): auctions and bids over a bus."""

    def __init__(
        self,
        transport: Transport,
        clock: Clock,
        *,
        agent_id: str | None = None,
        subjects: Iterable[str] | str = (),
        metric: Metric | None = None,
        on_start: StartCallback | None = None,
        on_stop: StopCallback | None = None,
        on_outcome: OutcomeCallback | None = None,
        observer: Observer | None = None,
        backoff: RandomizedBackoff | None = None,
        auto_idle: bool = True,
        rest_while_bidding: bool = True,
    ) -> None:
        self.transport = transport
        self.clock = clock
        self.agent_id = agent_id or transport.sender_id
        prefix = f"{self.agent_id}.{transport.instance[:6]}" if transport.instance else None
        self.auctioneer = Auctioneer(self.agent_id, observer, task_prefix=prefix)
        self.bidder = (
            Bidder(self.agent_id, metric, on_start, on_stop, observer)
            if metric is not None
            else None
        )
        self._subjects: SubjectSet = subject_set(subjects)
        self._on_outcome = on_outcome
        self._backoff = backoff
        self.auto_idle = auto_idle
        self.rest_while_bidding = rest_while_bidding
        """Between sending a bid and looking at the others (half-way through the window), a
        node with nothing else to wait for (no open auction, no contract) is not woken by
        traffic: `step(timeout_s)` rests until then and reads what came in one go."""
        self.outcomes: deque[Outcome] = deque(maxlen=1024)
        """The latest outcomes of tasks this node introduced (also sent to `on_outcome`)."""
        self._lock = threading.RLock()
        self._listening = self._wanted()
        self._sub = transport.subscribe(self._listening)
        self._sub.wake_on_replies = False
        self.closed = False

    # -- configuration
    @property
    def subjects(self) -> SubjectSet:
        return self._subjects

    @property
    def listening(self) -> SubjectSet:
        """Everything the node's subscription holds right now (resources, idle, negotiations)."""
        return self._wanted()

    @_locked
    def set_subjects(self, subjects: Iterable[str] | str) -> None:
        """Replace the resource subjects (empty: hear no announcements, e.g. while charging)."""
        self._subjects = subject_set(subjects)
        self._sync()

    # -- requester side
    @_locked
    def announce(self, spec: TaskSpec, patience_s: float | None = None) -> str:
        """Introduce a task; with `patience_s`, reintroduce it with backoff while unachievable."""
        now = self.clock()
        plan = None
        if patience_s is not None:
            if self._backoff is None:
                raise ValueError("reintroduction needs a node built with a backoff")
            plan = RetryPlan(now + patience_s, self._backoff.delay_s)
        task_id, out = self.auctioneer.announce(spec, now, retry=plan)
        self._sync()
        try:
            self._publish(out, strict=True)
        except WireError:
            self.auctioneer.cancel(task_id, now, "announcement could not be encoded")
            self.auctioneer.take_outcomes()
            self._sync()
            raise
        return task_id

    @_locked
    def cancel(self, task_id: str, reason: str = "cancelled") -> None:
        """Withdraw a task this node introduced; it ends as failed with `reason`."""
        self._publish(self.auctioneer.cancel(task_id, self.clock(), reason))
        self._deliver_outcomes()
        self._sync()

    @_locked
    def open_tasks(self) -> tuple[str, ...]:
        """The tasks this node introduced that have not ended yet."""
        return self.auctioneer.open_tasks()

    # -- executor side
    @property
    def executing(self) -> str | None:
        """The task this node's robot is executing under contract (None: none)."""
        bidder = self.bidder
        contract = bidder.contract if bidder is not None else None
        return contract.task_id if contract is not None else None

    @_locked
    def progress(self, task_id: str, fraction: float, note: str = "") -> None:
        if self.bidder is not None:
            self.bidder.progress(task_id, fraction, note)

    @_locked
    def complete(self, task_id: str, note: str = "") -> None:
        if self.bidder is not None:
            self._publish(self.bidder.complete(task_id, self.clock(), note))
            self._sync()

    @_locked
    def fail(self, task_id: str, reason: str) -> None:
        if self.bidder is not None:
            self._publish(self.bidder.fail(task_id, self.clock(), reason))
            self._sync()

    @_locked
    def abandon(self, task_id: str, reason: str) -> None:
        if self.bidder is not None:
            self._publish(self.bidder.abandon(task_id, self.clock(), reason))
            self._sync()

    @property
    def busy(self) -> bool:
        return self.bidder is not None and self.bidder.busy

    @property
    def bid_counters(self) -> dict[str, int]:
        """A copy of the bidder's counts of traffic about its own bids that left the usual
        course (late awards, refusals, expired bids: `murdoch.auction.BIDDER_COUNTERS`);
        empty for a node without a bidder."""
        return dict(self.bidder.counters) if self.bidder is not None else {}

    # -- the loop
    def step(self, timeout_s: float = 0.0) -> int:
        """Receive, handle, tick and publish once; return the number of messages handled.

        Waits at most `timeout_s` for traffic, less when the bidder wants to look at the
        other bids of an open round (`Bidder.next_wakeup`); while resting (see
        `rest_while_bidding`) traffic does not end the wait, only that time does."""
        with self._lock:  # (inline rather than @_locked: this runs on every loop)
            if self.closed:
                return 0
            if timeout_s > 0 and self.bidder is not None:
                look_at = self.bidder.next_wakeup()
                if look_at is not None:
                    timeout_s = max(0.0, min(timeout_s, look_at - self.clock()))
            self.transport.poll(timeout_s)
            envelopes = self._sub.drain()
            auctioneer, bidder, publish = self.auctioneer, self.bidder, self._publish
            for envelope in envelopes:
                now = envelope.received_at
                out = auctioneer.handle(envelope.message, now)
                if out:
                    publish(out)
                if bidder is not None:
                    out = bidder.handle(envelope.message, now)
                    if out:
                        publish(out)
            now = self.clock()
            out = auctioneer.tick(now)
            if out:
                publish(out)
            if bidder is not None:
                out = bidder.tick(now)
                if out:
                    publish(out)
            self._deliver_outcomes()
            self._sync()
            return len(envelopes)

    @_locked
    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._sub.close()

    # -- internals
    def _wanted(self) -> SubjectSet:
        subjects = set(self._subjects)
        if self.bidder is not None:
            if self.auto_idle and self._subjects and not self.bidder.busy:
                subjects.add(IDLE)
            subjects |= self.bidder.interest()
        subjects |= self.auctioneer.interest()
        return frozenset(subjects)

    def _sync(self) -> None:
        if self.closed:
            return
        wanted = self._wanted()
        if wanted != self._listening:
            self._sub.update(wanted)
            self._listening = wanted
        # on a transport with a reply lane, replies (bids, awards, progress, reports) wake the
        # node only when it expects them: its auctioneer has open tasks, or its bidder holds a
        # bid still in contention after looking at the others; otherwise they are read at the
        # next poll, before the rest (with one channel every datagram wakes it anyway)
        bidder = self.bidder
        auctioning = self.auctioneer.has_open_tasks
        self._sub.wake_on_replies = auctioning or (bidder is not None and bidder.expects_award)
        # a bidder that has just bid rests until it looks at the other bids: they (and any
        # other traffic) are read then in one go instead of waking it once each; anything
        # else that came meanwhile waits at most half the window of that bid
        self._sub.wake_on_traffic = not (
            self.rest_while_bidding
            and bidder is not None
            and not auctioning
            and bidder.contract is None
            and bidder.next_wakeup() is not None
        )

    def _publish(self, messages: list[Outgoing], strict: bool = False) -> None:
        for subjects, message in messages:
            try:
                self.transport.publish(subjects, message)
            except WireError as exc:
                if strict:
                    raise
                log.warning("could not encode %s: %s", message.KIND, exc)
            except OSError as exc:  # the round goes on; silence is handled like loss
                log.warning("could not send %s: %s", message.KIND, exc)

    def _deliver_outcomes(self) -> None:
        for outcome in self.auctioneer.take_outcomes():
            self.outcomes.append(outcome)
            if self._on_outcome is not None:
                self._on_outcome(outcome)
