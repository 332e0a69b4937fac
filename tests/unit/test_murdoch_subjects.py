from __future__ import annotations

import random
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from murdoch.subjects import SubjectError, SubjectIndex, matches, subject_set

NAMES = ["camera", "laser", "sonar", "bumper", "gripper", "mobile", "idle", "have-puck"]


def test_subset_rule_follows_the_paper() -> None:
    robot = subject_set("camera,laser,mobile,idle")
    assert matches(subject_set("camera,mobile,idle"), robot)
    assert not matches(subject_set("camera,bumper,mobile"), robot)
    assert matches(frozenset(), robot)


@pytest.mark.parametrize("bad", ["", "Camera", "has space", "-lead", "x" * 65, "a,b"])
def test_bad_subject_names_are_refused_with_the_rule(bad: str) -> None:
    with pytest.raises(SubjectError, match="expected"):
        subject_set([bad])


def test_comma_string_and_iterable_give_the_same_set() -> None:
    assert subject_set(" camera , mobile ") == subject_set(["mobile", "camera"])


@settings(max_examples=60, deadline=None)
@given(
    subs=st.lists(st.sets(st.sampled_from(NAMES), max_size=5), max_size=25),
    message=st.sets(st.sampled_from(NAMES), max_size=4),
    removed=st.sets(st.integers(0, 24)),
)
def test_index_agrees_with_brute_force(
    subs: list[set[str]], message: set[str], removed: set[int]
) -> None:
    index = SubjectIndex()
    live = {}
    for key, subjects in enumerate(subs):
        index.set(key, frozenset(subjects))
        live[key] = frozenset(subjects)
    for key in removed:
        index.remove(key)
        live.pop(key, None)
    expected = sorted(k for k, s in live.items() if frozenset(message) <= s)
    assert index.match(frozenset(message)) == expected
    assert len(index) == len(live)


def test_replacing_subjects_forgets_the_old_ones() -> None:
    index = SubjectIndex()
    index.set(1, frozenset({"camera", "idle"}))
    index.set(1, frozenset({"camera"}))
    assert index.match(frozenset({"idle"})) == []
    assert index.match(frozenset({"camera"})) == [1]


def test_matching_stays_fast_with_many_subscriptions() -> None:
    rng = random.Random(7)
    vocabulary = [f"s{i}" for i in range(200)]  # resources, states, negotiation subjects
    index = SubjectIndex()
    subscriptions = {}
    for key in range(800):
        subscriptions[key] = frozenset(rng.sample(vocabulary, 6))
        index.set(key, subscriptions[key])
    messages = [frozenset(rng.sample(vocabulary, 2)) for _ in range(500)]

    def indexed() -> float:
        start = time.perf_counter()
        for message in messages:
            index.match(message)
        return time.perf_counter() - start

    def linear() -> float:
        start = time.perf_counter()
        for message in messages:
            [k for k, subjects in subscriptions.items() if message <= subjects]
        return time.perf_counter() - start

    assert [index.match(m) for m in messages[:20]] == [
        sorted(k for k, s in subscriptions.items() if m <= s) for m in messages[:20]
    ]
    best_indexed = min(indexed() for _ in range(3))
    best_linear = min(linear() for _ in range(3))
    assert best_indexed * 4 < best_linear
