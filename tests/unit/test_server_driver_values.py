"""Drivers turn whatever numeric types the simulator hands over into encodable bodies."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from player_server.drivers.ranging import SonarDriver
from player_server.drivers.vision import BlobfinderDriver
from player_server.protocol import Decoder, encode_message
from player_server.protocol import sensor_msgs as sm
from player_server.sim.readings import Blob


class BlobSim:
    """Only what BlobfinderDriver reads: ``blobs(robot)``."""

    def __init__(self, blobs: tuple[Blob, ...]) -> None:
        self._blobs = blobs

    def blobs(self, robot: str) -> tuple[Blob, ...]:
        return self._blobs


def test_blob_pixels_from_floats_are_whole_and_non_negative() -> None:
    robot = SimpleNamespace(name="r", devices=SimpleNamespace(
        camera=SimpleNamespace(width_px=160, height_px=120)))
    blobs = (Blob(1, 0x00FF00, 24.0, 158.0, 67, 158, 159.7, 62, 73, 3.5),  # type: ignore[arg-type]
             Blob(2, 0x1FF0000, 5, 0, 1, -1.0, 3, -0.5, 2, 1.0))  # type: ignore[arg-type]
    ((subtype, body),) = BlobfinderDriver(BlobSim(blobs), robot).data()
    assert body == sm.BlobfinderData(160, 120, (
        sm.BlobfinderBlob(1, 0x00FF00, 24, 158, 67, 158, 159, 62, 73, 3.5),
        sm.BlobfinderBlob(2, 0xFF0000, 5, 0, 1, 0, 3, 0, 2, 1.0)))
    dec = Decoder()
    dec.feed(encode_message(7, 0, 1, subtype, body))
    assert [m.body for m in dec.events()] == [body]


class RangeSim:
    """Only what SonarDriver reads: ``sonar(robot)``."""

    def __init__(self, ranges: object) -> None:
        self._ranges = ranges

    def sonar(self, robot: str) -> object:
        return self._ranges


def _sonar_robot() -> SimpleNamespace:
    return SimpleNamespace(name="r", devices=SimpleNamespace(sonar=SimpleNamespace(
        max_range_m=5.0, poses=())))


@pytest.mark.parametrize("ranges", [
    np.array([0.5, 1.25, 5.0], dtype=np.float32),
    [0.5, 1.25, 5.0],
])
def test_clean_ranges_pass_unchanged(ranges: object) -> None:
    ((_, body),) = SonarDriver(RangeSim(ranges), _sonar_robot()).data()
    assert body == sm.SonarData((0.5, 1.25, 5.0))
    assert all(type(v) is float for v in body.ranges)


def test_bad_ranges_become_zero_and_the_rest_is_kept() -> None:
    ranges = np.array([0.5, np.nan, -0.25, np.inf, -np.inf, 2.0], dtype=np.float32)
    ((_, body),) = SonarDriver(RangeSim(ranges), _sonar_robot()).data()
    assert body == sm.SonarData((0.5, 0.0, 0.0, 0.0, 0.0, 2.0))
    ((_, empty),) = SonarDriver(RangeSim(np.zeros(0)), _sonar_robot()).data()
    assert empty == sm.SonarData(())
