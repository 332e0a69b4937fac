"""Priority and weighted-sum arbitration."""

from __future__ import annotations

import pytest

from behaviors.arbiter import Arbiter, Layer
from behaviors.basis import Hold
from behaviors.proposal import INACTIVE, Proposal

H = Hold()


def test_priority_highest_active_level_wins() -> None:
    arb = Arbiter([Layer(H, 2), Layer(H, 1), Layer(H, 1)], "priority")
    low_a = Proposal(True, 0.2, 0.0, 1.0)
    low_b = Proposal(True, 0.4, 0.4, 1.0)
    assert arb.combine([INACTIVE, low_a, low_b]) == pytest.approx((0.3, 0.2))
    assert arb.combine([Proposal(True, 0.0, -1.0, 0.5), low_a, low_b]) == (0.0, -1.0)


def test_weighted_sum_blends_by_weight_and_gain() -> None:
    arb = Arbiter([Layer(H, 5, gain=1.0), Layer(H, 0, gain=3.0)], "weighted")
    vx, vyaw = arb.combine([Proposal(True, 0.4, 0.0, 1.0), Proposal(True, 0.0, 0.8, 1.0)])
    assert vx == pytest.approx(0.1) and vyaw == pytest.approx(0.6)


def test_nothing_active_means_stop_and_output_is_clamped() -> None:
    arb = Arbiter([Layer(H, 0)], "priority", max_speed_mps=0.3, max_turn_radps=0.5)
    assert arb.combine([INACTIVE]) == (0.0, 0.0)
    assert arb.combine([Proposal(True, 9.0, -9.0, 1.0)]) == (0.3, -0.5)


def test_bad_mode_and_count_are_rejected() -> None:
    with pytest.raises(ValueError, match="mode"):
        Arbiter([], "vote")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="expected 1"):
        Arbiter([Layer(H)]).combine([])


def test_sensing_only_layer_never_steers() -> None:
    # A gain-0 layer at the lowest priority contributes its signal, never its motion.
    arb = Arbiter([Layer(H, 0), Layer(H, -1, gain=0.0)], "priority")
    assert arb.combine([Proposal(True, 0.2, 0.1, 1.0), Proposal(True, 0.5, 0.0, 1.0)]) == (
        0.2,
        0.1,
    )
    assert arb.combine([INACTIVE, Proposal(True, 0.5, 0.0, 1.0)]) == (0.0, 0.0)
