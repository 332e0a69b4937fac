from __future__ import annotations

import random

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


def test_hundreds_of_subscriptions_match_as_the_subset_rule_says() -> None:
    # a hundred-robot team's shape: resource subjects, idle, a negotiation subject each
    rng = random.Random(7)
    vocabulary = [f"s{i}" for i in range(40)]
    index = SubjectIndex()
    subscriptions = {}
    for key in range(600):
        subjects = {*rng.sample(vocabulary, rng.randint(0, 8)), f"task.{key % 150}"}
        if rng.random() < 0.7:
            subjects.add("idle")
        subscriptions[key] = frozenset(subjects)
        index.set(key, subscriptions[key])
    for key in range(0, 600, 7):  # some leave, some change what they hold
        if key % 2:
            index.remove(key)
            del subscriptions[key]
        else:
            subscriptions[key] = frozenset(rng.sample(vocabulary, 3))
            index.set(key, subscriptions[key])
    messages = [frozenset()] + [
        frozenset(rng.sample([*vocabulary, "idle", *(f"task.{n}" for n in range(150))],
                             rng.randint(1, 3)))
        for _ in range(400)]
    for message in messages:
        expected = sorted(k for k, s in subscriptions.items() if message <= s)
        assert index.match(message) == expected, message
    assert len(index) == len(subscriptions)
