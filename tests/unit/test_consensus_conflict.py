"""Every rule of CBBA's conflict-resolution table, through both evaluators."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.consensus.conflict import NONE, RULES, Action, classify, resolve, resolve_many

I, K, M, N = 0, 1, 2, 3  # receiver, sender, two other agents
U, R, L = Action.UPDATE, Action.RESET, Action.LEAVE
FRESH = ({M: 5.0, N: 5.0}, {M: 1.0, N: 1.0})  # (sender's s, receiver's s): sender knows better
STALE = ({M: 1.0, N: 1.0}, {M: 5.0, N: 5.0})

# (rule, z_kj, z_ij, y_kj, y_ij, (s_k, s_i), expected action)
CASES = [
    (1, K, I, 9.0, 5.0, FRESH, U), (1, K, I, 5.0, 9.0, FRESH, L),
    (1, K, I, 5.0, 5.0, FRESH, L),  # equal bids: lower index (the receiver, 0) keeps it
    (2, K, K, 1.0, 9.0, STALE, U),
    (3, K, M, 1.0, 9.0, FRESH, U), (3, K, M, 9.0, 1.0, STALE, U), (3, K, M, 1.0, 9.0, STALE, L),
    (4, K, NONE, 1.0, 0.0, STALE, U),
    (5, I, I, 9.0, 1.0, FRESH, L),
    (6, I, K, 9.0, 1.0, STALE, R),
    (7, I, M, 9.0, 1.0, FRESH, R), (7, I, M, 9.0, 1.0, STALE, L),
    (8, I, NONE, 9.0, 0.0, FRESH, L),
    (9, M, I, 9.0, 1.0, FRESH, U), (9, M, I, 1.0, 9.0, FRESH, L), (9, M, I, 9.0, 1.0, STALE, L),
    (10, M, K, 1.0, 9.0, FRESH, U), (10, M, K, 9.0, 1.0, STALE, R),
    (11, M, M, 1.0, 9.0, FRESH, U), (11, M, M, 9.0, 1.0, STALE, L),
    (12, M, N, 1.0, 9.0, FRESH, U),
    (12, M, N, 9.0, 1.0, ({M: 5.0, N: 1.0}, {M: 1.0, N: 5.0}), U),
    (12, M, N, 1.0, 9.0, ({M: 5.0, N: 1.0}, {M: 1.0, N: 5.0}), L),
    (12, M, N, 9.0, 1.0, ({M: 1.0, N: 5.0}, {M: 5.0, N: 1.0}), R),
    (12, M, N, 9.0, 1.0, STALE, L),
    (13, M, NONE, 1.0, 0.0, FRESH, U), (13, M, NONE, 1.0, 0.0, STALE, L),
    (14, NONE, I, 0.0, 9.0, FRESH, L),
    (15, NONE, K, 0.0, 9.0, STALE, U),
    (16, NONE, M, 0.0, 9.0, FRESH, U), (16, NONE, M, 0.0, 9.0, STALE, L),
    (17, NONE, NONE, 0.0, 0.0, FRESH, L),
]


def _many(z_k: int, z_i: int, y_k: float, y_i: float, s_k: dict[int, float],
          s_i: dict[int, float]) -> Action:
    def row(s: dict[int, float]) -> np.ndarray:
        out = np.full(5, -np.inf)
        for a, t in s.items():
            out[a] = t
        return out[None, :]

    code = resolve_many(np.array([I]), np.array([K]), np.array([[y_k]]), np.array([[z_k]]),
                        np.array([[y_i]]), np.array([[z_i]]), row(s_k), row(s_i))
    return Action(int(code[0, 0]))


def test_table_has_seventeen_distinct_rules() -> None:
    assert [r.number for r in RULES] == list(range(1, 18))
    assert len({(r.sender_believes, r.receiver_believes) for r in RULES}) == 17


@pytest.mark.parametrize(("rule", "z_k", "z_i", "y_k", "y_i", "stamps", "expected"), CASES)
def test_rule(rule: int, z_k: int, z_i: int, y_k: float, y_i: float,
              stamps: tuple[dict[int, float], dict[int, float]], expected: Action) -> None:
    s_k, s_i = stamps
    action, number = resolve(I, K, y_k, z_k, y_i, z_i, s_k, s_i)
    assert number == rule
    assert action == expected
    assert _many(z_k, z_i, y_k, y_i, s_k, s_i) == expected


def test_every_rule_is_exercised() -> None:
    assert {c[0] for c in CASES} == set(range(1, 18))


def test_classify_labels() -> None:
    assert classify(I, K, M, N) == ("m", "n")
    assert classify(I, K, M, M) == ("m", "m")
    assert classify(I, K, K, M) == ("k", "m")
    assert classify(I, K, NONE, NONE) == ("none", "none")


agent = st.sampled_from([NONE, 0, 1, 2, 3])


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(st.tuples(agent, agent, st.sampled_from([0.0, 1.0, 2.0]),
                          st.sampled_from([0.0, 1.0, 2.0])), min_size=1, max_size=8),
       st.lists(st.sampled_from([-np.inf, 1.0, 2.0, 3.0]), min_size=8, max_size=8))
def test_vectorised_matches_scalar(rows: list[tuple[int, int, float, float]],
                                   stamps: list[float]) -> None:
    s_k = {a: stamps[a] for a in range(4)}
    s_i = {a: stamps[4 + a] for a in range(4)}
    z_k = np.array([[r[0] for r in rows]])
    z_i = np.array([[r[1] for r in rows]])
    y_k = np.array([[0.0 if r[0] == NONE else r[2] for r in rows]])
    y_i = np.array([[0.0 if r[1] == NONE else r[3] for r in rows]])
    sk = np.array([[*stamps[:4], -np.inf]])
    si = np.array([[*stamps[4:], -np.inf]])
    got = resolve_many(np.array([I]), np.array([K]), y_k, z_k, y_i, z_i, sk, si)[0]
    for n in range(len(rows)):
        want, _ = resolve(I, K, float(y_k[0, n]), int(z_k[0, n]), float(y_i[0, n]),
                          int(z_i[0, n]), s_k, s_i)
        assert got[n] == want
