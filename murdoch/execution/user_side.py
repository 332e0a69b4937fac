"""The user's rules of the team-member contract (pure): attempts, leases, no winner, ends.

The user is whoever introduced a task (the runner, or a robot for its sub-tasks). Whatever
the allocator (an auction, consensus, a central decision), the user holds each task through
the same steps, decided here and nowhere else:

- `next_attempt`: an attempt starts unless `max_attempts` are spent (then the task fails);
- `Lease`: a granted task's hold on its executor, checked every tick by `Lease.check`:
  past the task's `timeout_s` it fails; an executor silent for `contract_timeout_s` is
  revoked and the task re-offered only after `abandon_after_s`, when the silent executor
  has given it up, so two executors never overlap; otherwise the grant is renewed every
  `renew_period_s`;
- `no_winner`: an attempt that found no executor within its bid window is retried after the
  user's backoff while its patience lasts, else it is `unachievable`;
- `on_report`: completed and failed end the task; abandoned or declined re-offer it at once;
- `outcome`: the one record of how a task ended (an unachievable task has no winner).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from murdoch.auction.messages import Outcome, TaskSpec

NO_BID = "no capable agent bid"
AT_ONCE_S = 0.0
"""How long an abandoned or declined task waits before it is offered again."""


def next_attempt(attempt: int, spec: TaskSpec) -> str | None:
    """Why no further attempt may start (None: it may)."""
    if attempt >= spec.max_attempts:
        return f"gave up after {attempt} attempts"
    return None


@dataclass(frozen=True)
class LeaseStep:
    """What a lease's check asks of the user: `expired` (the task fails with `reason`),
    `silent` (revoke, re-offer after `wait_s`) or `renew` (repeat the grant, the `n`th)."""

    kind: str
    reason: str = ""
    wait_s: float = 0.0
    n: int = 0


@dataclass
class Lease:
    """The user's hold on a granted task's executor."""

    winner: str
    awarded_at: float
    last_heard: float
    renew_at: float
    renewals: int = 0

    @classmethod
    def grant(cls, winner: str, now: float, spec: TaskSpec, renewals: int = 0) -> Lease:
        """A fresh grant; `renewals` numbers the renewals on from an earlier one (MURDOCH
        counts a task's renewals across its attempts)."""
        return cls(winner, now, now, now + spec.renew_period_s, renewals)

    def check(self, spec: TaskSpec, now: float, who: str | None = None,
              last_heard: float | None = None) -> LeaseStep | None:
        """The step due now (None: nothing). `who` and `last_heard` name the member judged
        for silence when it is not the winner (a group's quietest member)."""
        heard = self.last_heard if last_heard is None else last_heard
        if spec.timeout_s is not None and now - self.awarded_at > spec.timeout_s:
            return LeaseStep("expired", f"not finished within {spec.timeout_s:g} s")
        if now - heard > spec.contract_timeout_s:
            return LeaseStep("silent", f"{who or 'winner ' + self.winner} silent for "
                             f"{spec.contract_timeout_s:g} s", spec.abandon_after_s)
        if now >= self.renew_at:
            self.renewals += 1
            self.renew_at = now + spec.renew_period_s
            return LeaseStep("renew", n=self.renewals)
        return None


@dataclass(frozen=True)
class NoWinner:
    """An attempt without executor: retry after `retry_in_s`, or (None) unachievable with
    `final_reason`; `reason` is this attempt's."""

    reason: str
    retry_in_s: float | None
    final_reason: str = ""


def no_winner(now: float, spec: TaskSpec, attempt: int, rounds: int, last_reason: str,
              deadline: float | None, delay_s: Callable[[int], float] | None) -> NoWinner:
    """The `rounds`th attempt in a row without executor (counting this one)."""
    reason = NO_BID
    if attempt > 1 and last_reason:
        reason = f"{last_reason}; {NO_BID} on reallocation"
    if deadline is not None and delay_s is not None:
        delay = delay_s(rounds)
        if now + delay <= deadline and attempt < spec.max_attempts:
            return NoWinner(reason, delay)
        return NoWinner(reason, None, f"{reason}; retried {rounds - 1} times until the deadline")
    return NoWinner(reason, None, reason)


def on_report(status: str) -> str | None:
    """What the executor's report means to the user: `end` (completed, failed: the task
    ends so), `reoffer` (abandoned, declined: at once) or None (progress)."""
    if status in ("completed", "failed"):
        return "end"
    if status in ("abandoned", "declined"):
        return "reoffer"
    return None


def outcome(task_id: str, spec: TaskSpec, status: str, reason: str, winner: str | None,
            attempts: int, now: float) -> Outcome:
    return Outcome(task_id=task_id, name=spec.name, status=status, reason=reason,
                   winner=winner if status != "unachievable" else None, attempts=attempts,
                   time_s=now, parent=spec.parent)
