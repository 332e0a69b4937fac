"""Stage's model properties set through the simulation interface, over real TCP.

`color` changes what blobfinders see and `fiducial_return` the id fiducial detectors report,
from the next tick; other properties are NACKed, and so is every change without
--allow-world-control.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
from sibling import load_sibling

from player_server.client import BlobfinderProxy, FiducialProxy, PlayerNack
from player_server.client.device_proxies import SimulationProxy
from player_server.protocol import sensor_msgs as sm

INCLUDE = Path(__file__).resolve().parents[2] / "worlds" / "stage" / "include"

WORLD = f"""
include "{INCLUDE}/pioneer.inc"
include "{INCLUDE}/map.inc"
interval_sim 100

define scout pioneer2dx
(
  blobfinder( colors_count 1 colors [ "orange" ] image [ 80 60 ] range 6 fov 60 )
  fiducial( range_max 6 fov 180 )
)

scout( name "robot1" pose [ 0 0 0 0 ] )
scout( name "robot2" pose [ 2 0 0 180 ] color "blue" fiducial_return 7 )
zone( name "home" pose [ -3 -3 0 0 ] )
"""

CFG = """
driver ( name "stage" model "robot1"
         provides [ "7101:position2d:0" "7101:blobfinder:0" "7101:fiducial:0"
                    "7101:simulation:0" ]
         worldfile "props.world" )
driver ( name "stage" model "robot2" provides [ "7102:position2d:0" ] )
"""

_RGBA = struct.Struct("<4f")
_INT = struct.Struct("<i")


@pytest.fixture(scope="module")
def cfg(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("props")
    (d / "props.world").write_text(WORLD)
    (d / "props.cfg").write_text(CFG)
    return d / "props.cfg"


_stage = load_sibling(__file__, "stage_serving.py")
serve = _stage.robot1


def _blobs(proxy: BlobfinderProxy) -> tuple[sm.BlobfinderBlob, ...]:
    state = proxy.state if proxy.blob_values is not None else None
    return state.blobs if state is not None else ()


def test_color_and_fiducial_return_change_what_sensors_report(cfg: Path) -> None:
    with serve(cfg, world_control=True) as cl:
        sim = cl.subscribe(SimulationProxy)
        blobs = cl.subscribe(BlobfinderProxy)
        fids = cl.subscribe(FiducialProxy)
        for _ in range(3):
            cl.read()
        assert _blobs(blobs) == ()  # robot2 is blue; the blobfinder looks for orange
        assert [f.id for f in fids.fiducials] == [7]
        before = sim.get_property("robot2", "color")
        sim.set_property("robot2", "color", _RGBA.pack(1.0, 128 / 255, 0.0, 1.0))
        sim.set_property("robot2", "_mp_fiducial_return", _INT.pack(42))
        for _ in range(2):
            cl.read()
        assert len(_blobs(blobs)) == 1 and _blobs(blobs)[0].color == 0xFF8000  # the orange tracked
        assert 1.5 < _blobs(blobs)[0].range < 2.0
        assert [f.id for f in fids.fiducials] == [42]
        assert fids.fiducials[0].pose.px == pytest.approx(2.0, abs=0.1)
        rgba = _RGBA.unpack(sim.get_property("robot2", "color"))
        assert rgba == pytest.approx((1.0, 128 / 255, 0.0, 1.0), abs=1e-6)
        assert rgba != _RGBA.unpack(before)
        assert _INT.unpack(sim.get_property("robot2", "fiducial_return")) == (42,)
        # back to blue: the blob is gone; id 0: the detector no longer reports it
        sim.set_property("robot2", "color", _RGBA.pack(0.0, 0.0, 1.0, 1.0))
        sim.set_property("robot2", "fiducial_return", _INT.pack(0))
        for _ in range(2):
            cl.read()
        assert _blobs(blobs) == () and fids.fiducials == ()


@pytest.mark.parametrize(("name", "prop", "value"), [
    ("robot2", "mass", struct.pack("<d", 3.0)),  # a property that cannot change here
    ("robot2", "gripper_return", _INT.pack(1)),
    ("robot2", "color", _INT.pack(0xFF00)),  # not four float32
    ("robot2", "color", _RGBA.pack(math.nan, 0.0, 0.0, 1.0)),
    ("robot2", "color", _RGBA.pack(2.0, 0.0, 0.0, 1.0)),
    ("robot2", "fiducial_return", _INT.pack(-1)),
    ("robot2", "fiducial_return", b"\x01"),
    ("home", "color", _RGBA.pack(1.0, 0.0, 0.0, 1.0)),  # a zone: nothing sees it
    ("nobody", "color", _RGBA.pack(1.0, 0.0, 0.0, 1.0)),
])
def test_other_properties_and_bad_values_are_nacked(cfg: Path, name: str, prop: str,
                                                    value: bytes) -> None:
    with serve(cfg, world_control=True) as cl:
        sim = cl.subscribe(SimulationProxy)
        with pytest.raises(PlayerNack):
            sim.set_property(name, prop, value)
        assert _INT.unpack(sim.get_property("robot2", "fiducial_return")) == (7,)


def test_setting_properties_needs_world_control(cfg: Path) -> None:
    with serve(cfg, world_control=False) as cl:
        sim = cl.subscribe(SimulationProxy)
        fids = cl.subscribe(FiducialProxy)
        with pytest.raises(PlayerNack):
            sim.set_property("robot2", "fiducial_return", _INT.pack(42))
        for _ in range(2):
            cl.read()
        assert [f.id for f in fids.fiducials] == [7]
