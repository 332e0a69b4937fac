"""Per-tick readings made by `slot_maker` are ordinary frozen dataclass instances."""

from __future__ import annotations

import dataclasses
import math

import pytest

from behaviors.agent import AgentStatus
from behaviors.snapshot import (
    Blob,
    BlobView,
    Odometry,
    Pose2D,
    RangeScan,
    Snapshot,
    make_blob,
    make_blob_view,
    make_odometry,
    make_pose,
    make_scan,
    make_snapshot,
    slot_maker,
)


def test_made_readings_equal_constructed_ones_and_stay_frozen() -> None:
    blob = make_blob(0xFF0000, 10, 1.0, 2.0, 0, 3, 0, 4, math.inf)
    view = make_blob_view(80, 60, (blob,), 1.0, 2.5)
    odo = make_odometry(make_pose(1.0, 2.0, 0.5), 0.1, 0.0, False, 2.5)
    scan = make_scan((1.0, 2.0), (0.0, 0.1), 5.0, 2.5, (), 3)
    snap = make_snapshot(2.5, odo, None, scan, view, None, None, None, None)
    assert blob == Blob(0xFF0000, 10, 1.0, 2.0, 0, 3, 0, 4, math.inf)
    assert view == BlobView(80, 60, (blob,), 1.0, 2.5) and view.largest(0xFF0000) is blob
    assert odo == Odometry(Pose2D(1.0, 2.0, 0.5), 0.1, 0.0, False, 2.5)
    assert scan == RangeScan((1.0, 2.0), (0.0, 0.1), 5.0, 2.5, (), 3)
    assert snap == Snapshot(2.5, odo, None, scan, view) and snap.pose == Pose2D(1.0, 2.0, 0.5)
    for obj in (blob, view, odo, odo.pose, scan, snap):
        assert type(obj).__module__ == "behaviors.snapshot"
        assert dataclasses.is_dataclass(obj) and hash(obj) == hash(dataclasses.replace(obj))
        first = dataclasses.fields(obj)[0].name
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(obj, first, 0.0)
    assert snap.with_mark(None) == snap


def test_a_maker_for_another_frozen_class() -> None:
    make = slot_maker(AgentStatus)
    status = make("r1", "idle", 1.0, "", "", "", 0.0, 50.0, frozenset({"mobile"}))
    assert status == AgentStatus("r1", "idle", 1.0, battery_percent=50.0,
                                 subjects=frozenset({"mobile"}))
    assert type(status) is AgentStatus
