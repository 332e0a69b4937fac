"""The team-member contract's rules (murdoch.execution), one table each."""

from __future__ import annotations

import pytest

from murdoch.auction.timing import USER_TASK
from murdoch.execution.executor import EndReports, Execution
from murdoch.execution.user_side import Lease, next_attempt, no_winner, on_report, outcome

SPEC = USER_TASK.task("visit", {"mobile"}, {}, duration_s=30.0, timeout_s=100.0)
# renew every 2 s, revoke after 10 s of silence, the executor gives up after 10 s unrenewed


def test_a_lease_renews_each_period_revokes_a_silent_winner_and_expires() -> None:
    lease = Lease.grant("r1", 0.0, SPEC)
    assert lease.check(SPEC, 1.9) is None
    step = lease.check(SPEC, 2.0)
    assert step is not None and (step.kind, step.n) == ("renew", 1)
    assert lease.check(SPEC, 3.0) is None
    lease.last_heard = 9.0
    assert lease.check(SPEC, 19.0) is not None  # a renewal: heard 10 s ago is not silent
    silent = lease.check(SPEC, 19.1)
    assert silent is not None and silent.kind == "silent"
    assert silent.reason == "winner r1 silent for 10 s" and silent.wait_s == 10.0
    member = lease.check(SPEC, 19.1, "member r2", last_heard=5.0)
    assert member is not None and member.reason == "member r2 silent for 10 s"
    lease.last_heard = 100.0
    expired = lease.check(SPEC, 100.5)
    assert expired is not None and expired.kind == "expired"
    assert expired.reason == "not finished within 100 s"


@pytest.mark.parametrize(("attempt", "rounds", "last", "deadline", "retry", "reason", "final"), [
    (1, 1, "", 100.0, 5.0, "no capable agent bid", ""),
    (2, 1, "winner r1 silent", 100.0, 5.0,
     "winner r1 silent; no capable agent bid on reallocation", ""),
    (1, 3, "", 52.0, None, "no capable agent bid",
     "no capable agent bid; retried 2 times until the deadline"),
    (1, 1, "", None, None, "no capable agent bid", "no capable agent bid"),
    (SPEC.max_attempts, 1, "", 100.0, None, "no capable agent bid",
     "no capable agent bid; retried 0 times until the deadline"),
])
def test_no_winner_retries_with_backoff_while_patience_lasts(
        attempt: int, rounds: int, last: str, deadline: float | None, retry: float | None,
        reason: str, final: str) -> None:
    verdict = no_winner(50.0, SPEC, attempt, rounds, last, deadline, lambda n: 5.0)
    assert (verdict.reason, verdict.retry_in_s, verdict.final_reason) == (reason, retry, final)


def test_attempts_reports_and_outcomes() -> None:
    assert next_attempt(SPEC.max_attempts - 1, SPEC) is None
    assert next_attempt(SPEC.max_attempts, SPEC) == f"gave up after {SPEC.max_attempts} attempts"
    assert [on_report(s) for s in ("completed", "failed", "abandoned", "declined", "progress")] \
        == ["end", "end", "reoffer", "reoffer", None]
    assert outcome("t", SPEC, "unachievable", "x", "r1", 2, 9.0).winner is None
    assert outcome("t", SPEC, "completed", "x", "r1", 2, 9.0).winner == "r1"


def test_an_executor_reports_progress_and_gives_up_without_renewals() -> None:
    ex = Execution.start(0.0, abandon_after_s=10.0, progress_period_s=2.0)
    assert [ex.tick(t) for t in (1.0, 2.0, 3.0, 4.0)] == [None, "progress", None, "progress"]
    ex.renewed(5.0)
    assert ex.tick(15.0) == "progress" and ex.tick(15.1) == "abandon"
    assert ex.abandon_reason == "no renewal for 10 s"
    ex.progress(1.7, "almost")
    assert (ex.fraction, ex.note) == (1.0, "almost")


def test_end_reports_are_kept_for_the_latest_tasks() -> None:
    reports: EndReports[str] = EndReports(kept=2)
    for k in (1, 2, 3):
        reports.remember(k, f"report {k}")
    assert 1 not in reports and reports.get(3) == "report 3" and reports.get(1) is None
