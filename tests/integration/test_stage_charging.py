"""Stage charging models over real TCP: `give_watts` charges and `take_watts` drains the
battery of a robot whose body touches the model (within `contact.MARGIN_M`)."""

from __future__ import annotations

from contextlib import AbstractContextManager
from pathlib import Path

import pytest
from sibling import load_sibling

from player_server.client import PlayerClient, PowerProxy
from player_server.client.device_proxies import SimulationProxy
from worlds.stage import load_stage_world

INCLUDE = Path(__file__).resolve().parents[2] / "worlds" / "stage" / "include"

WORLD = f"""
include "{INCLUDE}/pioneer.inc"
include "{INCLUDE}/map.inc"
interval_sim 100

pioneer2dx( name "robot1" pose [ 0 0 0 0 ] )
charger( name "dock" pose [ 3 0 0 0 ] )
model( name "sink" pose [ -3 0 0 0 ] size [ 0.4 0.4 0.3 ] color "red" take_watts 500 )
"""

CFG = """
driver ( name "stage" model "robot1" provides [ "7301:position2d:0" "7301:power:0"
                                                "7301:simulation:0" ] worldfile "c.world" )
"""

# the pioneer's body: 0.44 m long, its centre 0.04 m behind the robot's origin
NOSE = 0.22 - 0.04  # from the origin to the front of the body
TAIL = 0.22 + 0.04


@pytest.fixture(scope="module")
def cfg(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("charging")
    (d / "c.world").write_text(WORLD)
    (d / "c.cfg").write_text(CFG)
    return d / "c.cfg"


_stage = load_sibling(__file__, "stage_serving.py")


def client(path: Path) -> AbstractContextManager[PlayerClient]:
    return _stage.robot1(path, world_control=True)


def _power_at(cl: PlayerClient, sim: SimulationProxy, power: PowerProxy, x: float,
              yaw: float) -> tuple[float, float, int]:
    """(joules lost over 5 ticks, watts, charging) with the robot put at (x, 0, yaw)."""
    sim.set_pose2d("robot1", x, 0.0, yaw)
    for _ in range(2):
        cl.read()
    assert power.state_values is not None
    before = power.state_values[3]
    for _ in range(5):
        cl.read()
    _, _, _, joules, watts, charging = power.state_values
    return before - joules, watts, charging


def test_a_robot_touching_a_giver_charges_and_touching_a_taker_is_drained(cfg: Path) -> None:
    spec = load_stage_world(cfg.with_name("c.world")).spec
    sink = next(c for c in spec.chargers if c.name == "sink")
    assert (sink.rate_w, sink.take_w, sink.size_x_m, sink.size_y_m) == (0.0, 500.0, 0.4, 0.4)
    with client(cfg) as cl:
        sim = cl.subscribe(SimulationProxy)
        power = cl.subscribe(PowerProxy)
        for _ in range(3):
            cl.read()
        lost, watts, charging = _power_at(cl, sim, power, 0.0, 0.0)
        assert watts == pytest.approx(-10.0) and charging == 0  # the idle draw (out: < 0)
        # facing away from the sink (3 m west), its tail 3 cm from the sink's east face
        idle = lost
        lost, watts, charging = _power_at(cl, sim, power, -2.8 + 0.03 + TAIL, 0.0)
        assert watts == pytest.approx(-510.0) and charging == 0
        assert lost == pytest.approx(51 * idle, rel=0.05)
        # 10 cm away: no contact
        lost, watts, charging = _power_at(cl, sim, power, -2.8 + 0.10 + TAIL, 0.0)
        assert watts == pytest.approx(-10.0)
        # nose 3 cm from the dock's west face (0.3 m deep at x = 3): charging
        lost, watts, charging = _power_at(cl, sim, power, 2.85 - 0.03 - NOSE, 0.0)
        assert charging == 1
        lost, watts, charging = _power_at(cl, sim, power, 2.85 - 0.10 - NOSE, 0.0)
        assert charging == 0
