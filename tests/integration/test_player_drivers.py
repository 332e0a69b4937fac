"""A contract every driver of every bundled world keeps, checked against the real simulator."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from player_server.drivers.base import Driver, Reply, Unsupported
from player_server.protocol import Decoder, Message, encode_message
from player_server.protocol import constants as c
from player_server.protocol.constants import Interface, MsgType
from player_server.protocol.registry import lookup, subtypes
from player_server.server.assembly import world_endpoints
from player_server.server.stage_assembly import plan_endpoints
from player_server.server.stage_source import load_stage_source
from player_server.sim import Simulation
from worlds import WORLDS_DIR, load_world

pytestmark = pytest.mark.timeout(120)

WORLDS = [*sorted(p.stem for p in WORLDS_DIR.glob("*.toml")), "stage/pioneers.cfg"]
ONLY_DATA_1 = {int(Interface.POWER), int(Interface.PTZ)}
MUST_HAVE_BODY: dict[int, tuple[int, ...]] = {
    int(Interface.POSITION2D): (c.PLAYER_POSITION2D_REQ_GET_GEOM,),
    int(Interface.LASER): (c.PLAYER_LASER_REQ_GET_GEOM, c.PLAYER_LASER_REQ_GET_CONFIG),
    int(Interface.RANGER): (c.PLAYER_RANGER_REQ_GET_GEOM, c.PLAYER_RANGER_REQ_GET_CONFIG,
                            c.PLAYER_RANGER_REQ_SET_CONFIG),
    int(Interface.SONAR): (c.PLAYER_SONAR_REQ_GET_GEOM,),
    int(Interface.GRIPPER): (c.PLAYER_GRIPPER_REQ_GET_GEOM,),
    int(Interface.BUMPER): (c.PLAYER_BUMPER_REQ_GET_GEOM,),
    int(Interface.FIDUCIAL): (c.PLAYER_FIDUCIAL_REQ_GET_GEOM, c.PLAYER_FIDUCIAL_REQ_GET_FOV),
    int(Interface.PTZ): (c.PLAYER_PTZ_REQ_GEOM, c.PLAYER_PTZ_REQ_STATUS),
    int(Interface.CAMERA): (c.PLAYER_CAMERA_REQ_GET_IMAGE,),
}


def roundtrip(interf: int, msg_type: int, subtype: int, body: object) -> object:
    wire = encode_message(interf, 0, msg_type, subtype, body, timestamp=1.0)
    dec = Decoder()
    dec.feed(wire)
    msg = dec.next_event()
    assert isinstance(msg, Message), msg
    return msg.body


def default_body(interf: int, subtype: int) -> object:
    cls = lookup(interf, int(MsgType.REQ), subtype)
    return None if cls is None else cls()


@pytest.fixture(scope="module", params=WORLDS)
def world_drivers(request: pytest.FixtureRequest) -> Iterator[list[tuple[str, Driver]]]:
    if request.param.endswith(".cfg"):  # a Player configuration and its Stage world
        stage, plan = load_stage_source(str(WORLDS_DIR / request.param), 0)
        spec = stage.spec
        sim = Simulation(spec)
        sim.step(2)
        eps = plan_endpoints(plan, stage, sim, ephemeral=True)
    else:
        spec = load_world(WORLDS_DIR / f"{request.param}.toml")
        sim = Simulation(spec)
        sim.step(2)
        eps = world_endpoints(spec, sim, 0)
    try:
        yield [(ep.name, d) for ep in eps for d in ep.drivers.values()]
    finally:
        sim.close()


def test_data_is_declared_encodable_and_sane(world_drivers: list[tuple[str, Driver]]) -> None:
    for name, drv in world_drivers:
        items = drv.data()
        if drv.interf == Interface.SIMULATION:
            assert items == (), "the simulation interface has no DATA"
            continue
        assert items, f"{name}: {drv.driver_name} produced no data"
        for subtype, body in items:
            assert subtype in subtypes(drv.interf, int(MsgType.DATA))
            if drv.interf in ONLY_DATA_1:
                assert subtype == 1
            assert roundtrip(drv.interf, 1, subtype, body) is not None
            if drv.interf == Interface.LASER:
                assert all(r >= 0 for r in body.ranges)
                assert len(body.intensity) in (0, len(body.ranges))
            if drv.interf in (Interface.SONAR, Interface.RANGER):
                assert all(r >= 0 for r in body.ranges)


def test_requests_answer_with_declared_bodies(world_drivers: list[tuple[str, Driver]]) -> None:
    for name, drv in world_drivers:
        for subtype in sorted(drv.requests):
            if drv.interf == Interface.SIMULATION:
                continue  # needs a name; covered over TCP
            try:
                reply = drv.handle_request(subtype, default_body(drv.interf, subtype))
            except (Unsupported, ValueError):  # not offered / values refused: both NACKed
                continue
            assert isinstance(reply, Reply)
            if reply.body is not None:
                roundtrip(drv.interf, int(MsgType.RESP_ACK), subtype, reply.body)
        # geometry and config requests must carry a body (libplayerc reads them unchecked)
        for subtype in MUST_HAVE_BODY.get(drv.interf, ()):
            body = default_body(drv.interf, subtype)
            assert drv.handle_request(subtype, body).body is not None, (name, subtype)
        with pytest.raises(Unsupported):
            drv.handle_request(200, None)
