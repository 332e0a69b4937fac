"""The sans-IO server core: dispatch, data rounds, replace rules, lockstep, bad input."""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable
from typing import Any

import pytest

from player_server.drivers.base import ACK, Driver, Reply, Unsupported, ack
from player_server.drivers.team_clock import TeamClock, TeamClockDriver
from player_server.protocol import NEED_DATA, Decoder, Message, encode_message
from player_server.protocol import actuator_msgs as am
from player_server.protocol import constants as c
from player_server.protocol import player_msgs as pm
from player_server.protocol.common import DevAddr, Pose2d, Pose3d
from player_server.protocol.team_clock import decode_table
from player_server.server.core import CoreConfig, ServerCore, Session
from player_server.server.endpoint import Endpoint


class FakePosition(Driver):
    """A position2d whose x is the publish counter of its owner; records commands."""

    interf = 4
    commands = frozenset({1})
    requests = frozenset({1, 5})

    def __init__(self, world: dict[str, float]) -> None:
        super().__init__(0, "fake_position2d")
        self.world = world
        self.cmds: list[Any] = []
        self.properties = {"max_speed": 0.5, "name": "p", "count": 3, "on": True}

    def data(self) -> list[tuple[int, Any]]:
        return [(1, am.Position2dData(Pose2d(self.world["t"], 0, 0), Pose2d(), 0))]

    def handle_command(self, subtype: int, body: Any) -> None:
        if subtype != 1:
            raise Unsupported(subtype)
        self.cmds.append(body)

    def handle_request(self, subtype: int, body: Any) -> Reply:
        if subtype == 1:
            return ack(am.Position2dGeom(Pose3d(0.1, 0, 0, 0, 0, 0)))
        if subtype == 5:
            raise ValueError("bad odometry")
        raise Unsupported(subtype)


class FakeSonar(Driver):
    interf = 5

    def __init__(self) -> None:
        super().__init__(0, "fake_sonar")

    def data(self) -> list[tuple[int, Any]]:
        from player_server.protocol.sensor_msgs import SonarData

        return [(1, SonarData((1.0, 2.0)))]


class Silent(Driver):
    interf = 31

    def handle_request(self, subtype: int, body: Any) -> Reply:
        return ACK


def make_core(**cfg: Any) -> tuple[ServerCore, dict[str, float], list[Endpoint]]:
    world = {"t": 0.0}
    eps = [
        Endpoint("r1", {(4, 0): FakePosition(world), (5, 0): FakeSonar(), (31, 0): Silent()},
                 port=7001),
        Endpoint("r2", {(4, 0): FakePosition(world)}, port=7002),
    ]
    core = ServerCore(eps, lambda: world["t"], CoreConfig(**cfg))
    return core, world, eps


def out(core: ServerCore, s: Session) -> list[Message]:
    dec = Decoder()
    dec.feed(core.take_output(s))
    msgs = []
    while (ev := dec.next_event()) is not NEED_DATA:
        assert isinstance(ev, Message)
        msgs.append(ev)
    return msgs


def req(interf: int, index: int, subtype: int, body: Any = None) -> bytes:
    return encode_message(interf, index, 3, subtype, body)


def sub(interf: int, index: int = 0, access: int = 1) -> bytes:
    return req(1, 0, 3, pm.DeviceReq(DevAddr(0, 0, interf, index), access, ""))


PULL = req(1, 0, 5, pm.DeviceDatamodeReq(2))
DATA = req(1, 0, 4)


def kinds(msgs: list[Message]) -> list[tuple[int, int, int]]:
    return [(m.type, m.interf, m.subtype) for m in msgs]


def connect(core: ServerCore, ep: Endpoint, pull: bool = True) -> Session:
    s = core.open_session(ep, "test")
    assert core.take_output(s) == c.banner()
    if pull:
        core.receive(s, PULL)
        assert kinds(out(core, s)) == [(4, 1, 5)]
    return s


def test_subscribe_and_pull_rounds() -> None:
    core, world, eps = make_core()
    s = connect(core, eps[0])
    core.receive(s, sub(4) + sub(5))
    acks = out(core, s)
    assert [m.body.driver_name for m in acks] == ["fake_position2d", "fake_sonar"]
    assert acks[0].body.addr == DevAddr(0, 7001, 4, 0) and acks[0].body.access == 1
    core.receive(s, DATA)
    msgs = out(core, s)
    assert kinds(msgs) == [(4, 1, 4), (1, 4, 1), (1, 5, 1), (5, 1, 1)]
    # the next round waits for a newer one; never an empty or repeated round
    core.receive(s, DATA)
    assert kinds(out(core, s)) == [(4, 1, 4)]
    world["t"] = 0.1
    core.publish()
    msgs = out(core, s)
    assert kinds(msgs) == [(1, 4, 1), (1, 5, 1), (5, 1, 1)]
    assert msgs[0].body.pos.px == 0.1 and msgs[0].timestamp == 0.1


def test_round_waits_for_a_subscription_with_data() -> None:
    core, _, eps = make_core()
    s = connect(core, eps[0])
    core.receive(s, sub(31) + DATA)  # simulation has no data
    assert kinds(out(core, s)) == [(4, 1, 3), (4, 1, 4)]
    core.publish()
    assert out(core, s) == []
    core.receive(s, sub(5))
    assert kinds(out(core, s)) == [(4, 1, 3), (1, 5, 1), (5, 1, 1)]


def test_unknown_device_and_modes() -> None:
    core, _, eps = make_core()
    s = connect(core, eps[1])
    core.receive(s, sub(6) + sub(4, 0, 7) + req(6, 0, 1) + req(4, 0, 1))
    msgs = out(core, s)
    assert kinds(msgs) == [(6, 1, 3), (6, 1, 3), (6, 6, 1), (6, 4, 1)]
    assert msgs[0].body == pm.DeviceReq(DevAddr(0, 7002, 6, 0), 3, "")
    # unsubscribe of a known device is ACKed with access 2
    core.receive(s, sub(4) + sub(4, 0, 2))
    msgs = out(core, s)
    assert [m.body.access for m in msgs] == [1, 2]


def test_player_device_requests() -> None:
    core, _, eps = make_core()
    s = connect(core, eps[0])
    core.receive(s, req(1, 0, 1) + req(1, 0, 2, pm.DeviceDriverInfo(DevAddr(0, 0, 5, 0), ""))
                 + req(1, 0, 2, pm.DeviceDriverInfo(DevAddr(0, 0, 9, 0), ""))
                 + req(1, 0, 7, pm.DeviceAuthReq(b"k")) + req(1, 0, 8, pm.DeviceNameserviceReq())
                 + req(1, 0, 10, pm.AddReplaceRuleReq(-1, -1, 1, -1, 1)) + req(1, 0, 99)
                 + req(1, 0, 3))  # DEV without a body
    msgs = out(core, s)
    assert [(m.type, m.subtype) for m in msgs] == [
        (4, 1), (4, 2), (6, 2), (6, 7), (6, 8), (4, 10), (6, 99), (6, 3)]
    assert [(d.interf, d.index) for d in msgs[0].body.devices] == [(4, 0), (5, 0), (31, 0)]
    assert msgs[1].body.driver_name == "fake_sonar"


def test_requests_commands_and_properties() -> None:
    core, _, eps = make_core()
    s = connect(core, eps[0])
    drv = eps[0].drivers[(4, 0)]
    assert isinstance(drv, FakePosition)
    vel = encode_message(4, 0, 2, 1, am.Position2dCmdVel(Pose2d(0.2, 0, 0.1), 1))
    core.receive(s, req(4, 0, 1) + vel)  # not subscribed: NACK, command dropped
    assert kinds(out(core, s)) == [(6, 4, 1)]
    assert drv.cmds == []
    core.receive(s, sub(4) + req(4, 0, 1) + vel + req(4, 0, 5, am.Position2dSetOdomReq())
                 + req(4, 0, 2, am.Position2dPowerConfig(1))
                 + encode_message(4, 0, 2, 3, am.Position2dCmdCar(1, 0)))
    msgs = out(core, s)
    assert kinds(msgs) == [(4, 1, 3), (4, 4, 1), (6, 4, 5), (6, 4, 2)]
    assert len(drv.cmds) == 1 and drv.cmds[0].vel.px == pytest.approx(0.2)
    core.receive(s, b"".join([
        req(4, 0, 252, pm.DblPropReq("max_speed", 0)),
        req(4, 0, 251, pm.DblPropReq("max_speed", 0.75)),
        req(4, 0, 252, pm.DblPropReq("max_speed", 0)),
        req(4, 0, 254, pm.IntPropReq("count", 0)),
        req(4, 0, 254, pm.IntPropReq("max_speed", 0)),  # wrong type
        req(4, 0, 250, pm.StrPropReq("name", "")),
        req(4, 0, 248, pm.BoolPropReq("on", 0)),
        req(4, 0, 247, pm.BoolPropReq("on", 0)),
        req(4, 0, 254, pm.IntPropReq("nope", 0)),
        req(4, 0, 255, pm.CapabilitiesReq(2, 1)),
        req(4, 0, 255, pm.CapabilitiesReq(2, 4)),
    ]))
    msgs = out(core, s)
    assert [m.type for m in msgs] == [4, 4, 4, 4, 6, 4, 4, 4, 6, 4, 6]
    assert msgs[0].body.value == 0.5 and msgs[2].body.value == 0.75
    assert msgs[3].body.value == 3 and msgs[5].body.value == "p" and msgs[6].body.value == 1
    assert drv.properties["on"] is False


def test_push_mode_and_replace_rules() -> None:
    core, world, eps = make_core()
    s = connect(core, eps[0], pull=False)
    core.receive(s, sub(4) + sub(5))
    out(core, s)
    for i in range(3):
        world["t"] = float(i)
        core.publish()
    msgs = out(core, s)  # default: the latest value replaces older queued data
    assert kinds(msgs) == [(1, 4, 1), (1, 5, 1)]
    assert msgs[0].body.pos.px == 2.0
    core.receive(s, req(1, 0, 10, pm.AddReplaceRuleReq(4, -1, 1, -1, 0))
                 + req(1, 0, 10, pm.AddReplaceRuleReq(-1, -1, -1, -1, 2)))
    out(core, s)
    for _ in range(3):
        core.publish()
    assert kinds(out(core, s)) == [(1, 4, 1)] * 3  # ACCEPT for position, IGNORE the rest


def test_queue_bound_drops_oldest_data_never_replies() -> None:
    core, _, eps = make_core(queue_limit=4)
    s = connect(core, eps[0], pull=False)
    core.receive(s, sub(4) + req(1, 0, 10, pm.AddReplaceRuleReq(-1, -1, -1, -1, 0)))
    for _ in range(10):
        core.publish()
    core.receive(s, req(1, 0, 1))
    msgs = out(core, s)
    assert [m.type for m in msgs].count(1) == 4
    assert [m.type for m in msgs].count(4) == 3
    assert s.queue.dropped == 6


def test_bad_input_is_nacked_counted_or_closes() -> None:
    core, _, eps = make_core(max_message_size=4096)
    s = connect(core, eps[0])
    other = connect(core, eps[0])
    garbage_req = struct.pack(">IIIIIIdII", 0, 0, 1, 0, 3, 3, 0.0, 0, 4) + b"\0\0\0\1"
    garbage_data = struct.pack(">IIIIIIdII", 0, 0, 4, 0, 1, 1, 0.0, 0, 0)
    core.receive(s, garbage_req + garbage_data + req(1, 0, 1))
    msgs = out(core, s)
    assert kinds(msgs) == [(6, 1, 3), (4, 1, 1)]
    assert s.counters.bad_messages == 2 and s.closing is None
    core.receive(s, struct.pack(">IIIIIIdII", 0, 0, 1, 0, 3, 1, 0.0, 0, 5000))
    assert s.closing is not None and "limit" in s.closing
    core.close_session(s)
    core.receive(other, req(1, 0, 1))
    assert kinds(out(core, other)) == [(4, 1, 1)]


def test_driver_failure_is_contained() -> None:
    core, _, eps = make_core()

    class Broken(FakeSonar):
        def data(self) -> list[tuple[int, Any]]:
            raise RuntimeError("boom")

        def handle_request(self, subtype: int, body: Any) -> Reply:
            raise RuntimeError("boom")

    eps[0].drivers[(5, 0)] = Broken()
    s = connect(core, eps[0])
    core.receive(s, sub(4) + sub(5) + req(5, 0, 1) + DATA)
    assert kinds(out(core, s)) == [(4, 1, 3), (4, 1, 3), (6, 5, 1), (4, 1, 4), (1, 4, 1),
                                   (5, 1, 1)]


def test_backpressure_on_unread_replies() -> None:
    core, _, eps = make_core(max_replies_waiting=10)
    s = connect(core, eps[0])
    core.receive(s, req(1, 0, 1) * 12)
    assert not core.accepting_input(s)
    out(core, s)
    assert core.accepting_input(s)


# -- lockstep ---------------------------------------------------------------------------------
def test_lockstep_waits_for_expected_participants_then_every_one() -> None:
    core, _, eps = make_core(lockstep=True, lockstep_clients=2, lockstep_timeout_s=5.0)
    a = connect(core, eps[0])
    monitor = connect(core, eps[0])
    core.receive(monitor, sub(5) + DATA)
    assert not core.lockstep_ready(0.0)  # no participant yet
    core.receive(a, sub(4) + DATA)
    out(core, a)
    core.receive(a, DATA)
    assert not core.lockstep_ready(0.0)  # only one of two expected
    b = connect(core, eps[1])
    core.receive(b, sub(4) + DATA)
    out(core, b)
    assert not core.lockstep_ready(0.0)  # b has not asked for the next round
    core.receive(b, DATA)
    assert core.lockstep_ready(0.0)  # the monitor does not hold the clock
    core.publish()
    assert kinds(out(core, b))[-1] == (5, 1, 1)
    assert not core.lockstep_ready(0.0)


def test_lockstep_override_and_timeout() -> None:
    core, _, eps = make_core(lockstep=True, lockstep_clients=1, lockstep_timeout_s=5.0)
    a = connect(core, eps[0])
    slow = connect(core, eps[1])
    core.receive(slow, req(1, 0, 253, pm.IntPropReq("lockstep", 1)) + sub(4) + DATA)
    core.receive(a, req(1, 0, 253, pm.IntPropReq("lockstep", 0)) + sub(4) + DATA + DATA)
    core.receive(a, req(1, 0, 254, pm.IntPropReq("lockstep", 0)))
    assert out(core, a)[-1].body.value == 0
    assert not core.lockstep_ready(0.0)  # slow consumed round 0 but asks nothing more
    core.receive(slow, DATA)
    assert core.lockstep_ready(0.1)
    core.publish()
    assert not core.lockstep_ready(1.0)
    assert not core.lockstep_ready(6.5)  # demoted now
    assert core.counters.demoted == 1
    assert core.participants() == []
    assert not core.lockstep_ready(7.0)  # nobody holds the clock: wait
    core.receive(slow, DATA)  # asking again: it holds the clock again
    assert core.participants() == [slow] and core.lockstep_ready(7.5)


def test_lockstep_steps_on_without_participants_only_when_told_and_none_is_expected() -> None:
    for told in (False, True):
        core, _, eps = make_core(lockstep=True, step_without_participants=told)
        assert not core.lockstep_ready(0.0)  # none seen yet: a run's team is still starting
        a = connect(core, eps[0])
        core.receive(a, sub(4) + DATA)
        out(core, a)
        core.receive(a, DATA)
        assert core.lockstep_ready(0.0)
        core.close_session(a)  # the whole team is gone
        restarting = {"alive": True}
        core.expect("r2", functools.partial(restarting.__getitem__, "alive"))
        assert not core.lockstep_ready(0.1)  # one is coming back: wait for it
        restarting["alive"] = False  # it died before it joined
        assert core.lockstep_ready(0.2) is told  # a bare server waits for a client


def test_lockstep_first_round_grace() -> None:
    core, _, eps = make_core(lockstep=True, lockstep_clients=1, lockstep_timeout_s=5.0)
    setting_up = connect(core, eps[0])
    core.receive(setting_up, sub(4))
    assert not core.lockstep_ready(0.0)
    assert not core.lockstep_ready(10.0) and core.counters.demoted == 0  # within 4 x 5 s
    assert not core.lockstep_ready(21.0) and core.counters.demoted == 1


def test_disconnect_unsubscribes() -> None:
    core, _, eps = make_core(lockstep=True)
    a = connect(core, eps[0])
    core.receive(a, sub(4))
    assert core.participants() == [a]
    core.close_session(a)
    assert core.participants() == [] and a.subs == {}


class CountingPosition(FakePosition):
    """Counts how often its data is read; velocity commands only set a target."""

    deferred_commands = frozenset({1})

    def __init__(self, world: dict[str, float]) -> None:
        super().__init__(world)
        self.reads = 0

    def data(self) -> list[tuple[int, Any]]:
        self.reads += 1
        return super().data()


def test_prepared_round_survives_deferred_commands_only() -> None:
    world = {"t": 0.0}
    drv = CountingPosition(world)
    ep = Endpoint("r1", {(4, 0): drv, (31, 0): Silent()}, port=7001)
    core = ServerCore([ep], lambda: world["t"], CoreConfig(lockstep=True, pipelined=True))
    s = connect(core, ep)
    core.receive(s, sub(4) + sub(31))
    out(core, s)
    world["t"] = 0.1
    core.prepare()
    assert drv.reads == 1
    vel = encode_message(4, 0, 2, 1, am.Position2dCmdVel(Pose2d(0.2, 0, 0.1), 1))
    core.receive(s, vel + DATA)  # a target for the next step: the prepared data still holds
    core.publish()
    msgs = out(core, s)
    assert drv.reads == 1 and drv.cmds and msgs[-2].body.pos.px == 0.1
    world["t"] = 0.2
    core.prepare()
    core.receive(s, req(31, 0, 1) + DATA)  # any request may change state: read afresh
    core.publish()
    out(core, s)
    assert drv.reads == 3


def test_a_device_whose_data_the_client_ignores_is_not_computed() -> None:
    world = {"t": 0.0}
    drv = CountingPosition(world)
    ep = Endpoint("r1", {(4, 0): drv, (5, 0): FakeSonar()}, port=7001)
    core = ServerCore([ep], lambda: world["t"], CoreConfig())
    s = connect(core, ep)
    skip = c.PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE
    ignore = req(1, 0, 10, pm.AddReplaceRuleReq(4, 0, 1, -1, skip))
    core.receive(s, sub(4) + sub(5) + ignore + DATA)
    msgs = out(core, s)
    assert kinds(msgs)[-2:] == [(1, 5, 1), (5, 1, 1)] and drv.reads == 0
    # a rule for one subtype only: the device is still read (other subtypes may pass)
    s2 = connect(core, ep)
    one = req(1, 0, 10, pm.AddReplaceRuleReq(4, 0, 1, 1, skip))
    core.receive(s2, sub(4) + sub(5) + one + DATA)
    assert (1, 4, 1) not in kinds(out(core, s2)) and drv.reads == 1


def test_connection_cap_grows_with_the_worlds_ports_unless_given() -> None:
    from player_server.server.session import connection_cap

    assert connection_cap(CoreConfig(), 2) == 64
    assert connection_cap(CoreConfig(), 101) == 404  # a hundred robots and a camera
    assert connection_cap(CoreConfig(max_connections=3), 101) == 3


def test_a_participant_put_back_into_the_lockstep_reads_the_round_as_it_was_published() -> None:
    """A robot paused while it waited (taken out of the lockstep, then put back) asks for
    its next round only after the others have moved on: it still gets the round of the
    tick it was put back in, with that tick's state and team clock table, whatever the
    others declared and the simulation stepped before it asked."""
    world = {"t": 0.0}
    clock = TeamClock()
    eps = [Endpoint(name, {(4, 0): FakePosition(world),
                           (c.Interface.OPAQUE, 0): TeamClockDriver(clock, name)}, port=port)
           for name, port in (("r1", 7001), ("r2", 7002))]
    core = ServerCore(eps, lambda: world["t"], CoreConfig(lockstep=True, pipelined=True))
    a, b = (connect(core, ep) for ep in eps)
    for s in (a, b):
        core.receive(s, sub(4) + sub(c.Interface.OPAQUE) + DATA)
        out(core, s)

    def round_of(s: Session) -> tuple[float, dict[str, int]]:
        msgs = out(core, s)
        pose = next(m.body.pos.px for m in msgs if m.interf == 4 and m.type == 1)
        table = next(m.body.data for m in msgs if m.interf == c.Interface.OPAQUE)
        return pose, decode_table(bytes(table))

    def tick(t: float, hook: Callable[[], None] = lambda: None) -> None:
        assert core.lockstep_ready(t)
        world["t"] = t
        hook()  # the runner's turn: it pauses or continues robots here
        core.publish()

    core.receive(a, DATA)
    core.receive(b, DATA)
    tick(0.1, functools.partial(setattr, b, "lockstep_override", False))  # paused, waiting
    assert round_of(b)[0] == 0.1  # already on its way
    for t in (0.2, 0.3):
        core.receive(a, DATA)
        tick(t)
        out(core, a)
    clock.declare("r1/0", 5)
    core.receive(a, DATA)
    tick(0.4, functools.partial(setattr, b, "lockstep_override", None))  # continued
    assert round_of(a) == (0.4, {"r1/0": 5})
    assert not core.lockstep_ready(0.4)  # b has not asked yet
    world["t"] = 0.5  # the next step, and a declares what it sent at 0.4, before b asks
    clock.declare("r1/0", 7)
    core.receive(b, DATA)
    assert round_of(b) == (0.4, {"r1/0": 5})
    core.receive(a, DATA)
    assert not core.lockstep_ready(0.5)  # b works on its round
    core.receive(b, DATA)
    assert core.lockstep_ready(0.5)
