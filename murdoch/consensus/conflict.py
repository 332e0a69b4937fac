"""CBBA's conflict-resolution table (receiver i, sender k) as data, and two evaluators of it.

Each rule is chosen by what the sender k and the receiver i believe about task j's winner
(k, i, m, n or none, where m and n are other agents) and holds ordered clauses: the first
clause whose conditions all hold gives the action; no clause holding means LEAVE.

Condition names (m is the rule's m, n is the receiver's winner in rule 12):

- ``y_kj>y_ij``: the sender's bid beats the receiver's (equal bids: the lower agent index wins)
- ``s_km>s_im``: the sender heard from m more recently than the receiver did
- ``s_kn>s_in``: the sender heard from n more recently than the receiver did
- ``s_im>s_km``: the receiver heard from m more recently than the sender did

`resolve` evaluates one task with plain values (readable, the reference); `resolve_lists`
applies a whole message to an agent's (y, z) lists in place (what the allocators use);
`resolve_many` evaluates a batch of (receiver, task) pairs with numpy. All three must agree
everywhere (`test_consensus_conflict.py`, `test_consensus_gains.py`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

NONE = -1  # "no winner"


class Action(IntEnum):
    LEAVE = 0
    UPDATE = 1
    RESET = 2


@dataclass(frozen=True)
class Rule:
    number: int
    sender_believes: str  # "k", "i", "m", "none"
    receiver_believes: str  # "i", "k", "m", "n", "none"
    m_is: str  # whose winner the rule calls m: "sender", "receiver" or "-"
    clauses: tuple[tuple[tuple[str, ...], Action], ...]


U, R = Action.UPDATE, Action.RESET
RULES: tuple[Rule, ...] = (
    Rule(1, "k", "i", "-", ((("y_kj>y_ij",), U),)),
    Rule(2, "k", "k", "-", (((), U),)),
    Rule(3, "k", "m", "receiver", ((("s_km>s_im",), U), (("y_kj>y_ij",), U))),
    Rule(4, "k", "none", "-", (((), U),)),
    Rule(5, "i", "i", "-", ()),
    Rule(6, "i", "k", "-", (((), R),)),
    Rule(7, "i", "m", "receiver", ((("s_km>s_im",), R),)),
    Rule(8, "i", "none", "-", ()),
    Rule(9, "m", "i", "sender", ((("s_km>s_im", "y_kj>y_ij"), U),)),
    Rule(10, "m", "k", "sender", ((("s_km>s_im",), U), ((), R))),
    Rule(11, "m", "m", "sender", ((("s_km>s_im",), U),)),
    Rule(12, "m", "n", "sender", (
        (("s_km>s_im", "s_kn>s_in"), U),
        (("s_km>s_im", "y_kj>y_ij"), U),
        (("s_kn>s_in", "s_im>s_km"), R),
    )),
    Rule(13, "m", "none", "sender", ((("s_km>s_im",), U),)),
    Rule(14, "none", "i", "-", ()),
    Rule(15, "none", "k", "-", (((), U),)),
    Rule(16, "none", "m", "receiver", ((("s_km>s_im",), U),)),
    Rule(17, "none", "none", "-", ()),
)

SENDER_CODES = ("k", "i", "m", "none")
RECEIVER_CODES = ("i", "k", "m", "n", "none")


def rule_for(sender_believes: str, receiver_believes: str) -> Rule:
    for rule in RULES:
        if rule.sender_believes == sender_believes and rule.receiver_believes == receiver_believes:
            return rule
    raise KeyError((sender_believes, receiver_believes))


def _named(i: int, k: int) -> dict[int, str]:
    """The winners a belief names by label: the receiver i, the sender k and nobody."""
    return {i: "i", k: "k", NONE: "none"}


@functools.cache
def _codes(i: int, k: int) -> tuple[dict[int, int], dict[int, int]]:
    """`_named` as the sender's and the receiver's codes (`SENDER_CODES`, `RECEIVER_CODES`);
    any other winner is "m" (2) to both (the receiver's "n", 3, is decided per task)."""
    named = _named(i, k)
    return ({z: SENDER_CODES.index(b) for z, b in named.items()},
            {z: RECEIVER_CODES.index(b) for z, b in named.items()})


def classify(i: int, k: int, z_kj: int, z_ij: int) -> tuple[str, str]:
    """The (sender, receiver) belief labels of the table for one task: "i", "k" or "none"
    for a winner that is the receiver i, the sender k (never the same agent) or nobody;
    otherwise "m", and for the receiver "n" when the sender believes in another "m"."""
    named = _named(i, k)
    sb = named.get(z_kj, "m")
    rb = named.get(z_ij)
    if rb is None:
        rb = "n" if sb == "m" and z_ij != z_kj else "m"
    return sb, rb


def bid_beats(y_a: float, z_a: int, y_b: float, z_b: int) -> bool:
    """Whether bid (y_a by z_a) beats (y_b by z_b): higher value, then lower agent index."""
    if y_a != y_b:
        return y_a > y_b
    if z_a == NONE:
        return False
    return z_b == NONE or z_a < z_b


def resolve(i: int, k: int, y_kj: float, z_kj: int, y_ij: float, z_ij: int,
            s_k: dict[int, float], s_i: dict[int, float]) -> tuple[Action, int]:
    """The action receiver i takes for one task on sender k's message, and the rule number."""
    sb, rb = classify(i, k, z_kj, z_ij)
    rule = rule_for(sb, rb)
    if rule.m_is == "sender":
        m = z_kj
    elif rule.m_is == "receiver":
        m = z_ij
    else:
        m = NONE
    n = z_ij
    neg = float("-inf")
    facts = {
        "y_kj>y_ij": bid_beats(y_kj, z_kj, y_ij, z_ij),
        "s_km>s_im": s_k.get(m, neg) > s_i.get(m, neg),
        "s_kn>s_in": s_k.get(n, neg) > s_i.get(n, neg),
        "s_im>s_km": s_i.get(m, neg) > s_k.get(m, neg),
    }
    return _decide(rule, facts), rule.number


# ------------------------------------------------------------------- vectorised evaluation


def _fact_values(rule: Rule, beats: bool, fresh_sender_m: bool, fresh_receiver_m: bool,
                 stale_sender_m: bool) -> dict[str, bool]:
    skm = fresh_sender_m if rule.m_is == "sender" else fresh_receiver_m
    sim_gt = stale_sender_m if rule.m_is == "sender" else False
    return {"y_kj>y_ij": beats, "s_km>s_im": skm, "s_kn>s_in": fresh_receiver_m,
            "s_im>s_km": sim_gt}


def _decide(rule: Rule, facts: dict[str, bool]) -> Action:
    for conditions, action in rule.clauses:
        if all(facts[c] for c in conditions):
            return action
    return Action.LEAVE


def _compile() -> tuple[np.ndarray, np.ndarray]:
    """Rule number by (sender code, receiver code), and the action by (rule number, facts)
    where facts packs four bits: bid beats, sender fresher about the sender's winner, sender
    fresher about the receiver's winner, receiver fresher about the sender's winner."""
    table = np.zeros((len(SENDER_CODES), len(RECEIVER_CODES)), dtype=np.int64)
    for rule in RULES:
        table[SENDER_CODES.index(rule.sender_believes),
              RECEIVER_CODES.index(rule.receiver_believes)] = rule.number
    lut = np.zeros((len(RULES) + 1, 16), dtype=np.int64)
    for rule in RULES:
        for code in range(16):
            facts = _fact_values(rule, bool(code & 1), bool(code & 2), bool(code & 4),
                                 bool(code & 8))
            lut[rule.number, code] = int(_decide(rule, facts))
    return table, lut


_TABLE, _LUT = _compile()


def rule_arrays() -> tuple[np.ndarray, np.ndarray]:
    """The table as the arrays `resolve_many` indexes (copies): rule number by (sender code,
    receiver code), and action by (rule number, facts code)."""
    return _TABLE.copy(), _LUT.copy()


def resolve_many(i: np.ndarray, k: np.ndarray, y_k: np.ndarray, z_k: np.ndarray,
                 y_i: np.ndarray, z_i: np.ndarray, s_k: np.ndarray, s_i: np.ndarray
                 ) -> np.ndarray:
    """Actions for a batch: i, k are (B,) agent indices; y, z are (B, M); s are (B, N + 1)
    timestamp rows whose last column is -inf (looked up for "no winner"). Returns (B, M)
    Action codes."""
    ii = i[:, None]
    kk = k[:, None]
    s_code = np.where(z_k == kk, 0, np.where(z_k == ii, 1, np.where(z_k == NONE, 3, 2)))
    r_code = np.where(
        z_i == ii, 0,
        np.where(z_i == kk, 1,
                 np.where(z_i == NONE, 4,
                          np.where((s_code == 2) & (z_i != z_k), 3, 2))))
    rule_no = _TABLE[s_code, r_code]
    rows = np.arange(z_k.shape[0])[:, None]
    sk_at_zk = s_k[rows, z_k]
    si_at_zk = s_i[rows, z_k]
    beats = (y_k > y_i) | ((y_k == y_i) & (z_k != NONE) & ((z_i == NONE) | (z_k < z_i)))
    code = (beats.astype(np.int64) + 2 * (sk_at_zk > si_at_zk)
            + 4 * (s_k[rows, z_i] > s_i[rows, z_i]) + 8 * (si_at_zk > sk_at_zk))
    return _LUT[rule_no, code]


# ------------------------------------------------------------- scalar evaluation on lists

_TABLE_T: tuple[tuple[int, ...], ...] = tuple(map(tuple, _TABLE.tolist()))
_LUT_T: tuple[tuple[int, ...], ...] = tuple(map(tuple, _LUT.tolist()))


def resolve_lists(i: int, k: int, y_i: list[float], z_i: list[int], s_i: list[float],
                  y_k: list[float], z_k: list[int], s_k: list[float],
                  first: int = 0, end: int | None = None) -> bool:
    """Apply sender k's (y, z) to receiver i's lists in place for tasks [first, end), the
    same actions as `resolve_many`; True if anything changed. The timestamp lists hold one
    entry per agent and a last -inf one (index NONE = -1 looks it up)."""
    if y_k == y_i and z_k == z_i:
        return False  # equal beliefs never change anything
    stop = len(y_i) if end is None else end
    changed = False
    table, lut = _TABLE_T, _LUT_T
    sender_code, receiver_code = _codes(i, k)
    differ = [j for j in range(first, stop) if z_k[j] != z_i[j] or y_k[j] != y_i[j]]
    for j in differ:
        zk = z_k[j]
        zi = z_i[j]
        yk = y_k[j]
        yi = y_i[j]
        sc = sender_code.get(zk, 2)
        rc = receiver_code.get(zi, 2)
        if rc == 2 and sc == 2 and zi != zk:
            rc = 3
        sk_zk = s_k[zk]
        si_zk = s_i[zk]
        beats = yk > yi or (yk == yi and zk != NONE and (zi == NONE or zk < zi))
        code = ((1 if beats else 0) + (2 if sk_zk > si_zk else 0)
                + (4 if s_k[zi] > s_i[zi] else 0) + (8 if si_zk > sk_zk else 0))
        action = lut[table[sc][rc]][code]
        if action == 1:
            y_i[j] = yk
            z_i[j] = zk
            changed = True
        elif action == 2 and (yi != 0.0 or zi != NONE):
            y_i[j] = 0.0
            z_i[j] = NONE
            changed = True
    return changed
