"""The bus's loss layer (pure): seeded drops, bounded delays, a clear error for bad specs."""

from __future__ import annotations

import pytest

from murdoch.lossy import LossSpec, LossyReceiver


def test_drops_and_delays_are_seeded_and_bounded() -> None:
    now = [0.0]
    a = LossyReceiver(LossSpec(0.25, 0.5, 3), "p1", lambda: now[0])
    b = LossyReceiver(LossSpec(0.25, 0.5, 3), "p1", lambda: now[0])
    other = LossyReceiver(LossSpec(0.25, 0.5, 3), "p2", lambda: now[0])
    for n in range(400):
        for r in (a, b, other):
            r.offer(b"%d" % n)
    assert a.dropped == b.dropped and 60 <= a.dropped <= 140
    assert other.dropped != a.dropped  # each receiver draws its own
    now[0] = 0.5
    out = a.due()
    assert len(out) == 400 - a.dropped and not a.pending()
    assert sorted(out, key=int) != out  # delays reorder


def test_a_bad_spec_says_what_was_expected() -> None:
    assert LossSpec.parse("0.02,0.05,13") == LossSpec(0.02, 0.05, 13)
    for text in ("0.02,0.05", "x,1,2", "1.5,0,1"):
        with pytest.raises(ValueError, match="LOSS,DELAY_S,SEED"):
            LossSpec.parse(text)
