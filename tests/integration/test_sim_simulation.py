"""The Simulation on real PyBullet (DIRECT): geometry checked by hand, physics, devices."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from player_server.sim import Blob, Simulation
from worlds import load_world

WORLD = """
name = "scene"
[sim]
seed = 5
[arena]
size = [6.0, 4.0]
wall_height = 0.5

[[boxes]]
name = "box"
pose = [2.0, 0.0, 0]
size = [0.4, 0.4, 0.4]
mass = 1.5
colour = "yellow"

[[objects]]
name = "red"
pose = [2.0, 0.8, 0]
radius = 0.1
height = 0.3
colour = "red"

[[objects]]
name = "pick"
pose = [-2.5, 1.5, 0]
radius = 0.05
height = 0.2
colour = "blue"
fiducial_id = 9

[[chargers]]
name = "dock"
position = [-2.0, 1.0]
radius = 0.4
rate = 200.0

[overhead_camera]
name = "overhead"

[[robots]]
name = "r"
pose = [0, 0, 0]
[robots.position2d]
max_speed = 0.5
[robots.sonar]
[robots.laser]
[robots.camera]
[robots.blobfinder]
channels = ["red", "yellow"]
[robots.bumper]
[robots.gripper]
[robots.ptz]
[robots.fiducial]
[robots.power]
capacity = 100.0
idle_draw = 10.0
moving_draw = 20.0
sensor_draw = 0.0

[[robots]]
name = "r2"
pose = [-2.5, -1.5, 0]
[robots.position2d]
"""


@pytest.fixture()
def world(tmp_path: Path) -> Path:
    p = tmp_path / "scene.toml"
    p.write_text(WORLD)
    return p


@pytest.fixture()
def sim(world: Path) -> Iterator[Simulation]:
    s = Simulation(load_world(world))
    yield s
    s.close()


def test_names_and_errors(sim: Simulation) -> None:
    assert sim.robot_names() == ("r", "r2")
    assert set(sim.body_names()) == {"r", "r2", "box", "red", "pick"}
    assert sim.tick == 0 and sim.time_s == 0.0 and sim.interval_s == pytest.approx(0.1)
    with pytest.raises(KeyError):
        sim.get_pose("nobody")
    with pytest.raises(KeyError):
        sim.laser("nobody")
    with pytest.raises(ValueError, match="no laser"):
        sim.laser("r2")
    with pytest.raises(ValueError):
        sim.gripper_command("r", "squeeze")


def test_laser_and_sonar_match_hand_geometry(sim: Simulation) -> None:
    laser = sim.laser("r")
    assert laser.dtype == np.float32 and laser.shape == (181,)
    # Laser at x = 0.16: the box face at x = 1.8 straight ahead, the side walls at y = +-2.
    assert laser[90] == pytest.approx(1.64, abs=1e-3)
    assert laser[0] == pytest.approx(2.0, abs=1e-3)
    assert laser[180] == pytest.approx(2.0, abs=1e-3)
    # 45 degrees left: towards the red cylinder at (2.0, 0.8)? no: the ray y = x - 0.16 meets
    # the wall y = 2 at x = 2.16 (inside the 3 m half-length).
    assert laser[135] == pytest.approx(2.0 * math.sqrt(2), abs=1e-3)
    sonar = sim.sonar("r")
    assert sonar.shape == (16,)
    assert sonar[0] == pytest.approx(2.0 - 0.136, abs=1e-3)
    assert sonar[7] == pytest.approx(2.0 - 0.136, abs=1e-3)
    assert sonar[3] == pytest.approx((3.0 - 0.166) / math.cos(math.radians(10)), abs=1e-3)
    assert sonar[11] == pytest.approx((3.0 - 0.255) / math.cos(math.radians(10)), abs=1e-3)
    # Cached within the tick, fresh after a step.
    assert sim.laser("r") is laser
    sim.step()
    assert sim.laser("r") is not laser


def test_blob_matches_pinhole_projection(sim: Simulation) -> None:
    blobs = sim.blobs("r")
    red = [b for b in blobs if b.colour == 0xFF0000]
    yellow = [b for b in blobs if b.colour == 0xFFFF00]
    assert len(red) == 1 and len(yellow) == 1
    b = red[0]
    assert b.id == 0 and yellow[0].id == 1
    f = 80 / math.tan(math.radians(30))
    dx, dy = 2.0 - 0.10, 0.8
    d = math.hypot(dx, dy)
    bearing = math.atan2(dy, dx)
    half = math.asin(0.1 / d)
    assert b.l == pytest.approx(80 - f * math.tan(bearing + half), abs=1.0)
    assert b.r == pytest.approx(80 - f * math.tan(bearing - half), abs=1.0)
    assert b.range_m == pytest.approx(d - 0.1, abs=1e-6)
    # The top edge is the cylinder top (0.3 m, below the 0.34 m camera) at the near side.
    top = 60 + f * (0.34 - 0.3) / ((d - 0.1) * math.cos(bearing))
    bottom = 60 + f * 0.34 / ((d - 0.1) * math.cos(bearing))
    assert b.t == pytest.approx(top, abs=1.0)
    assert b.b == pytest.approx(min(bottom, 119), abs=1.0)
    assert b.area == (b.r - b.l + 1) * (b.b - b.t + 1)


def test_blob_occlusion_and_ptz(sim: Simulation) -> None:
    # A box on the line of sight hides the red cylinder.
    sim.set_pose("box", 1.0, 0.4, 0.0)
    assert not [b for b in sim.blobs("r") if b.colour == 0xFF0000]
    sim.set_pose("box", 2.0, -1.0, 0.0)
    assert [b for b in sim.blobs("r") if b.colour == 0xFF0000]
    # Panning the camera 60 degrees left loses it (field of view +-30 degrees).
    sim.ptz_command("r", math.radians(60), 0.0, math.radians(60))
    sim.step(5)
    assert sim.ptz("r").pan == pytest.approx(math.radians(40), abs=1e-6)  # 80 deg/s
    assert sim.ptz("r").pan_speed == pytest.approx(math.radians(80))
    sim.step(5)
    assert sim.ptz("r").pan == pytest.approx(math.radians(60))
    assert not [b for b in sim.blobs("r") if b.colour == 0xFF0000]


def test_drive_acceleration_odometry_and_turning(sim: Simulation) -> None:
    sim.set_velocity("r", 2.0, 0.0)  # clamped to 0.5
    sim.step()
    assert sim.odometry("r").vx == pytest.approx(0.05, abs=1e-6)  # 0.5 m/s^2 for 0.1 s
    sim.set_velocity("r", 0.3, 0.0)
    sim.step(29)
    x, y, yaw = sim.get_pose("r")
    assert x == pytest.approx(0.3 * 3.0 - 0.3 ** 2 / (2 * 0.5), abs=0.03)
    assert abs(y) < 1e-3 and abs(yaw) < 1e-3
    odo = sim.odometry("r")
    assert (odo.x, odo.y, odo.yaw) == pytest.approx((x, y, yaw), abs=1e-9)
    assert odo.vx == pytest.approx(0.3, abs=1e-3) and not odo.stall
    sim.set_velocity("r", 0.0, 1.0)
    sim.step(20)
    x2, y2, yaw2 = sim.get_pose("r")
    assert math.hypot(x2 - x, y2 - y) < 0.3 ** 2 / (2 * 0.5) + 0.01  # braking, then a turn
    assert yaw2 > 1.0
    sim.set_odometry("r", 1.0, 2.0, 0.5)
    assert sim.odometry("r").x == 1.0 and sim.odometry("r").yaw == 0.5
    assert sim.drive_command("r") == (0.0, 1.0)
    sim.set_motor_power("r", False)
    sim.set_velocity("r", 0.5, 0.0)
    assert sim.drive_command("r") == (0.0, 0.0)  # motors off: the drive steers to rest
    sim.step(10)
    assert sim.odometry("r").vx == 0.0


def test_stall_against_a_wall(sim: Simulation) -> None:
    sim.set_pose("r", 2.5, -1.2, 0.0)
    sim.set_velocity("r", 0.4, 0.0)
    sim.step(30)
    x, _, _ = sim.get_pose("r")
    assert x <= 3.0 - 0.1825 + 0.02
    assert sim.odometry("r").stall
    assert any(sim.bumpers("r")[:5])


def test_pushing_a_box_presses_the_front_bumper(sim: Simulation) -> None:
    sim.set_pose("r", 1.2, 0.0, 0.0)
    assert not any(sim.bumpers("r"))
    sim.set_velocity("r", 0.3, 0.0)
    pressed = []
    for _ in range(40):
        sim.step()
        pressed.append(sim.bumpers("r"))
    bx, by, _ = sim.get_pose("box")
    assert bx > 2.3 and abs(by) < 0.1
    assert any(p[2] for p in pressed)  # middle front panel
    assert not any(any(p[5:]) for p in pressed)  # rear panels untouched


def test_gripper_grips_carries_and_releases(sim: Simulation) -> None:
    sim.set_pose("r", -1.0, -1.0, 0.0)
    sim.set_pose("pick", -0.7, -1.0, 0.0)
    g = sim.gripper("r")
    assert g.state == "open" and g.beams == 1 and g.holding is None
    sim.gripper_command("r", "close")
    assert sim.gripper("r").state == "moving"
    sim.step(10)
    g = sim.gripper("r")
    assert g.state == "closed" and g.holding == "pick" and g.beams == 3
    sim.set_velocity("r", 0.3, 0.0)
    sim.step(20)
    rx, ry, _ = sim.get_pose("r")
    px, py, _ = sim.get_pose("pick")
    assert rx > -0.6 and px == pytest.approx(rx + 0.28, abs=0.03) and py == pytest.approx(ry,
                                                                                         abs=0.03)
    sim.gripper_command("r", "store")
    assert sim.gripper("r").stored == 1 and sim.gripper("r").holding is None
    assert "pick" not in {b.name for b in sim.snapshot().bodies}
    sim.gripper_command("r", "retrieve")
    assert sim.gripper("r").holding == "pick"
    sim.set_velocity("r", 0.0, 0.0)
    sim.gripper_command("r", "open")
    sim.step(12)
    assert sim.gripper("r").state == "open" and sim.gripper("r").holding is None


def test_battery_drains_stops_robot_and_charges(sim: Simulation) -> None:
    p = sim.power("r")
    assert p.percent == 100.0 and p.joules == 100.0 and not p.charging
    sim.set_velocity("r", 0.5, 0.0)
    sim.set_pose("r", -2.3, -0.5, 0.0)
    sim.set_velocity("r", 0.0, 0.0)
    sim.step(10)
    assert sim.power("r").watts == pytest.approx(10.0)
    assert sim.power("r").joules == pytest.approx(90.0)
    sim.set_battery("r", 0.0)
    sim.set_velocity("r", 0.3, 0.0)
    sim.step(5)
    assert sim.odometry("r").vx == 0.0  # flat: the motors do not move
    sim.set_pose("r", -2.0, 1.0, 0.0)  # onto the charger
    sim.step(5)
    p = sim.power("r")
    assert p.charging and p.joules == pytest.approx((200.0 - 10.0) * 0.5, abs=1.0)
    assert p.volts > 10.5
    sim.step(2)
    assert sim.odometry("r").vx > 0.0  # recovered above the resume fraction


def test_a_charger_switched_off_charges_nobody_until_it_is_on_again(sim: Simulation) -> None:
    sim.set_battery("r", 0.5)
    sim.set_pose("r", -2.0, 1.0, 0.0)  # on the charger
    sim.set_charger_enabled("dock", False)
    assert not sim.charger_enabled("dock")
    sim.step(5)
    p = sim.power("r")
    assert not p.charging and p.joules < 50.0
    sim.set_charger_enabled("dock", True)
    sim.step(5)
    assert sim.power("r").charging and sim.power("r").joules > p.joules
    with pytest.raises(KeyError, match="no charger named"):
        sim.set_charger_enabled("nowhere", False)
    sim.set_charger_enabled("dock", False)
    sim.reset()
    assert sim.charger_enabled("dock")


def test_overhead_snapshot_fiducials_pause(sim: Simulation) -> None:
    seen = {t.name: t for t in sim.overhead()}
    assert set(seen) == {"r", "r2", "box", "red", "pick"}
    assert seen["red"].colour == 0xFF0000 and seen["red"].kind == "object"
    assert seen["r"].kind == "robot"
    snap = sim.snapshot()
    assert snap.tick == 0 and {b.name for b in snap.bodies} == set(seen)
    sim.set_pose("r", -1.5, -1.5, math.pi)
    fids = sim.fiducials("r")
    assert [f.id for f in fids] == [2, 9]  # r2 1 m ahead, then the can off to the right
    assert fids[0].x == pytest.approx(1.0 - 0.16, abs=1e-6)
    sim.set_paused(True)
    assert sim.step(5) == 0 and sim.paused
    sim.set_paused(False)
    assert sim.step(5) == 5


def test_fast_and_render_agree(world: Path) -> None:
    spec = load_world(world)
    fast = Simulation(spec)
    render = Simulation(spec, fidelity="render")
    try:
        for s in (fast, render):
            s.set_pose("r", -0.5, 0.3, 0.2)
            s.set_pose("pick", 1.0, -1.2, 0.0)
        lf, lr = fast.laser("r"), render.laser("r")
        assert np.max(np.abs(lf - lr)) < 0.01
        sf, sr = fast.sonar("r"), render.sonar("r")
        assert np.max(np.abs(sf - sr)) < 0.01
        bf = {b.colour: b for b in fast.blobs("r")}
        br = {b.colour: b for b in render.blobs("r")}
        assert set(bf) == set(br) == {0xFF0000, 0xFFFF00}
        for colour in bf:
            a, b = bf[colour], br[colour]
            assert abs(a.x - b.x) <= 3 and abs(a.y - b.y) <= 4
            assert abs(a.l - b.l) <= 3 and abs(a.r - b.r) <= 3
            assert 0.6 < b.area / a.area < 1.4
            assert b.range_m == pytest.approx(a.range_m, abs=0.1)
        img = fast.camera_image("r")
        assert img.shape == (120, 160, 3) and img.dtype == np.uint8
        red = (img[:, :, 0] > 200) & (img[:, :, 1] < 60) & (img[:, :, 2] < 60)
        assert red.any()
    finally:
        fast.close()
        render.close()


def test_blob_is_a_frozen_value() -> None:
    b = Blob(0, 0xFF0000, 4, 1, 1, 0, 2, 0, 2, 1.0)
    with pytest.raises(AttributeError):
        b.area = 5  # type: ignore[misc]


def test_more_device_edges(sim: Simulation) -> None:
    with pytest.raises(KeyError):
        sim.set_pose("ghost", 0.0, 0.0, 0.0)
    with pytest.raises(ValueError):
        sim.step(-1)
    with pytest.raises(ValueError):
        sim.set_velocity("r", math.nan, 0.0)
    # PTZ targets are clamped to the head's limits.
    sim.ptz_command("r", math.radians(500), math.radians(-90), math.radians(1))
    sim.step(40)
    p = sim.ptz("r")
    assert p.pan == pytest.approx(math.radians(100)) and p.tilt == pytest.approx(
        math.radians(-25)) and p.zoom == pytest.approx(math.radians(4.4))
    # Backing into the box presses a rear panel only.
    sim.set_pose("r", 2.5, 0.0, 0.0)
    sim.set_velocity("r", -0.3, 0.0)
    sim.step(15)
    pressed = sim.bumpers("r")
    assert any(pressed[5:]) and not any(pressed[:5])
    # Paddles stopped half-way are open and hold nothing.
    sim.gripper_command("r", "close")
    sim.step(3)
    sim.gripper_command("r", "stop")
    assert sim.gripper("r").state == "open"


def test_stored_objects_vanish_and_markers_move(world: Path, tmp_path: Path) -> None:
    text = world.read_text() + (
        '\n[[markers]]\nname = "goal"\nposition = [2.5, -1.0]\ncolour = "yellow"\n'
    )
    p = tmp_path / "with_goal.toml"
    p.write_text(text)
    with Simulation(load_world(p)) as sim:
        sim.set_pose("box", -2.5, -1.5, 0.0)  # out of view
        assert [b.colour for b in sim.blobs("r")] == [0xFF0000, 0xFFFF00]  # can, goal post
        sim.set_pose("goal", -2.0, 1.5, 0.0)  # behind the robot
        assert [b.colour for b in sim.blobs("r")] == [0xFF0000]
        assert sim.get_pose("goal")[:2] == (-2.0, 1.5)
        sim.set_pose("r", -1.0, -1.0, 0.0)
        sim.set_pose("pick", -0.72, -1.0, 0.0)  # between the paddles
        assert [f.id for f in sim.fiducials("r")] == [9]
        sim.gripper_command("r", "close")
        sim.step(10)
        assert sim.gripper("r").holding == "pick"
        sim.gripper_command("r", "store")
        assert "pick" not in {t.name for t in sim.overhead()}
        assert not sim.fiducials("r")


def test_bad_fidelity_is_refused(world: Path) -> None:
    with pytest.raises(ValueError, match="fidelity"):
        Simulation(load_world(world), fidelity="photoreal")
