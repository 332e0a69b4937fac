"""The optional metric terms: the paper's distance example and its specialist bonus."""

from __future__ import annotations

import math

import pytest

from behaviors.library import (
    DISTANCE_WEIGHT,
    SPECIALIST_WEIGHT,
    bid_terms,
    parse_bid_terms,
    task_spec,
)
from behaviors.metrics import place_distance, spare_resources
from behaviors.params import ParamError
from behaviors.profile import RobotProfile
from behaviors.snapshot import Blob, BlobView, Odometry, Pose2D, Snapshot
from worlds import load_world, world_path

RED = 0xFF0000
LANDMARKS = ((RED, 4.0, 0.0), (RED, -1.0, 0.0), (0x00FF00, 0.0, 0.0))
GENERALIST = frozenset({"mobile", "sonar", "laser", "camera", "power"})  # p1
SPECIALIST = frozenset({"mobile", "sonar", "camera", "power"})  # p5


def at(x: float, y: float, red_in_view: bool = True) -> Snapshot:
    blobs = (Blob(RED, 100, 80, 60, 70, 90, 50, 70, 2.0),) if red_in_view else ()
    return Snapshot(1.0, odometry=Odometry(Pose2D(x, y, 0.0), 0, 0, False, 1.0),
                    camera=BlobView(160, 120, blobs, math.radians(60), 1.0))


def profile(subjects: frozenset[str], terms: tuple[str, ...] = ()) -> RobotProfile:
    return RobotProfile("r", subjects, landmarks=LANDMARKS, bid_terms=terms)


def test_parse_bid_terms() -> None:
    assert parse_bid_terms("") == ()
    assert parse_bid_terms("default") == ()
    assert parse_bid_terms("distance, specialist,distance") == ("distance", "specialist")
    with pytest.raises(ParamError, match=r"unknown metric term.*charisma.*known: distance"):
        parse_bid_terms("distance,charisma")


def test_place_distance_to_the_nearest_object_of_the_colour_or_the_task_place() -> None:
    metric = place_distance()
    p = profile(SPECIALIST)
    assert metric(at(0.0, 0.0), {"colour": "red"}, p) == pytest.approx(-1.0)
    assert metric(at(3.0, 0.0), {"colour": "red"}, p) == pytest.approx(-1.0)
    assert metric(at(0.0, 0.0), {"x": 3.0, "y": 4.0}, p) == pytest.approx(-5.0)
    # nothing to measure to: the term does not tell robots apart
    assert metric(at(0.0, 0.0), {"colour": "blue"}, p) == 0.0
    assert metric(at(0.0, 0.0), {}, p) == 0.0
    assert metric(Snapshot(1.0), {"colour": "red"}, p) == 0.0


def test_spare_resources_count_what_the_task_does_not_need() -> None:
    tracking = task_spec("object-tracking").subjects
    resources = frozenset({"mobile", "sonar", "laser", "camera", "bumper", "overhead-camera"})
    metric = spare_resources(tracking, resources)
    assert metric(at(0, 0), {}, profile(SPECIALIST)) == -1.0  # sonar
    assert metric(at(0, 0), {}, profile(GENERALIST)) == -2.0  # sonar, laser


def test_terms_are_off_by_default_and_added_when_asked() -> None:
    tracking = task_spec("object-tracking")
    snap, params = at(0.0, 0.0), {"colour": "red"}
    plain = tracking.score(snap, params, profile(SPECIALIST))
    assert plain == pytest.approx(1.0 + 0.5 * 0.5)  # visible, battery unknown
    with_distance = tracking.score(snap, params, profile(SPECIALIST, ("distance",)))
    assert with_distance == pytest.approx(plain - DISTANCE_WEIGHT * 1.0)
    names = [m.name for m in bid_terms(tracking, ("distance", "specialist"))]
    assert names == ["distance", "specialist"]


def test_a_specialist_defeats_a_generalist_that_is_better_placed() -> None:
    """The paper's proposal: the camera-only robot wins tracking even against a generalist
    that sees the colour while it does not, and is nearer."""
    tracking = task_spec("object-tracking")
    params = {"colour": "red"}
    terms = ("distance", "specialist")
    specialist = tracking.score(at(-5.0, 5.0, red_in_view=False), params,
                                profile(SPECIALIST, terms))
    generalist = tracking.score(at(-1.0, 0.5), params, profile(GENERALIST, terms))
    assert specialist is not None and generalist is not None
    assert specialist > generalist
    # without the bonus the better placed generalist wins
    near = tracking.score(at(-1.0, 0.5), params, profile(GENERALIST, ("distance",)))
    far = tracking.score(at(-5.0, 5.0, red_in_view=False), params,
                         profile(SPECIALIST, ("distance",)))
    assert near is not None and far is not None and near > far
    assert SPECIALIST_WEIGHT > 1.0 + 0.5 + DISTANCE_WEIGHT * 16.0


def test_longterm_robots_know_where_the_coloured_things_are() -> None:
    from behaviors.robot import profile_from

    world = load_world(world_path("longterm"))
    p = profile_from("p5", frozenset({"position2d", "camera", "sonar"}), world,
                     bid_terms=("distance",))
    assert (RED, 3.5, 2.5) in p.landmarks
    assert p.bid_terms == ("distance",)
