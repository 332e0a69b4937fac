"""The server against hostile and broken clients, live over loopback TCP with real PyBullet.

Every test bounds its loops in count and time; none asserts on wall time.
"""

from __future__ import annotations

import logging
import math
import random
import socket
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from typing import Any

import pytest
from sibling import load_sibling

from player_server.client import LaserProxy, PlayerClient, PlayerNack, Position2dProxy
from player_server.drivers.base import Driver
from player_server.protocol import constants as c
from player_server.protocol import sensor_msgs as sm
from player_server.protocol.constants import Interface, MsgType
from player_server.server.assembly import world_endpoints
from player_server.server.core import CoreConfig
from player_server.server.runner import PlayerServer
from player_server.sim import Simulation
from worlds import load_world, world_path

hw = load_sibling(__file__, "hostile_wire.py")
child_process = load_sibling(__file__, "child_process.py")

pytestmark = pytest.mark.timeout(120)
ACK, NACK = int(MsgType.RESP_ACK), int(MsgType.RESP_NACK)
P2D = int(Interface.POSITION2D)


@contextmanager
def serve(world: str = "simple", *, speedup: float = 20.0, world_control: bool = False,
          extra: Callable[[Any, list[Any]], None] | None = None,
          **config: Any) -> Iterator[PlayerServer]:
    spec = load_world(world_path(world))
    sim = Simulation(spec, seed=3)
    endpoints = world_endpoints(spec, sim, 0, allow_world_control=world_control)
    if extra is not None:
        extra(sim, endpoints)
    server = PlayerServer(sim, endpoints, interval_s=sim.interval_s, clock=time.monotonic,
                          speedup=speedup, config=CoreConfig(**config))
    try:
        server.start()
        yield server
    finally:
        server.stop()  # re-raises whatever the serving thread died of
        sim.close()


def wait_for(cond: Callable[[], bool], timeout_s: float = 30.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if cond():
            return
        time.sleep(0.01)
    raise AssertionError(f"timed out waiting for {what or cond}")


def alive(server: PlayerServer, port_name: str = "robot1") -> None:
    """The serving thread runs and answers a fresh client."""
    assert server.error is None and not server.finished.is_set()
    with PlayerClient("127.0.0.1", server.ports[port_name], timeout_s=10.0) as cl:
        assert cl.devlist()


def test_non_finite_properties_are_refused_and_commands_never_kill_the_server() -> None:
    with serve() as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        cl.send(hw.subscribe(P2D))
        assert cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_DEV) == ACK
        for key in ("max_speed", "max_yaw_rate"):
            for bad in (math.nan, math.inf, -1.0, 1e200):
                cl.send(hw.dbl_prop(P2D, key, bad))
                assert cl.wait_reply(P2D, c.PLAYER_SET_DBLPROP_REQ) == NACK, (key, bad)
        cl.send(hw.dbl_prop(P2D, "max_speed", 0.2))
        assert cl.wait_reply(P2D, c.PLAYER_SET_DBLPROP_REQ) == ACK
        for bad in (math.nan, math.inf, 1e200):
            cl.send(hw.velocity(bad, 0.1) + hw.vel_head(0.2, bad) + hw.vel_head(bad, 1.0)
                    + hw.position_goal(bad, 0.0, 0.0) + hw.position_goal(1e200, 0.0, 0.0))
        cl.send(hw.vel_head(0.2, 1.0) + hw.position_goal(0.5, 0.0, 0.0))  # fine ones
        # refused: every NaN and inf (10) and the two goals beyond the odometry range at
        # 1e200; huge but finite speeds and angles are clamped or wrapped (accepted)
        wait_for(lambda: srv.core.counters.commands_refused >= 12, what="commands refused")
        alive(srv)
        assert srv.core.counters.commands_refused == 12


def test_world_control_needs_the_flag_and_poses_stay_inside_the_arena() -> None:
    with serve() as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        cl.send(hw.subscribe(int(Interface.SIMULATION)))
        assert cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_DEV) == ACK
        cl.send(hw.set_pose2d("robot1", 1.0, 1.0, 0.0))
        assert cl.wait_reply(int(Interface.SIMULATION), 2) == NACK
        cl.send(hw.set_pose3d("box1", 1.0, 1.0, 0.0))
        assert cl.wait_reply(int(Interface.SIMULATION), 4) == NACK
        cl.send(hw.sim_command(c.PLAYER_SIMULATION_CMD_PAUSE)
                + hw.sim_command(c.PLAYER_SIMULATION_CMD_RESET))
        t0 = srv.sim.time_s
        wait_for(lambda: srv.sim.time_s > t0 + 1.0, what="time to pass (not paused)")
        assert not srv.sim.paused
        with PlayerClient("127.0.0.1", srv.ports["robot1"], timeout_s=10.0) as pc:
            from player_server.client import SimulationProxy
            x, y, _ = pc.subscribe(SimulationProxy).get_pose2d("robot1")  # reading stays open
            assert math.isfinite(x) and math.isfinite(y)
    with serve(world_control=True) as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        cl.send(hw.subscribe(int(Interface.SIMULATION)))
        assert cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_DEV) == ACK
        for x, y in ((1e200, 0.0), (math.nan, 0.0), (0.0, -math.inf), (50.0, 0.0)):
            cl.send(hw.set_pose2d("robot1", x, y, 0.0))
            assert cl.wait_reply(int(Interface.SIMULATION), 2) == NACK, (x, y)
        cl.send(hw.set_pose2d("robot1", 1.0, -1.0, 0.0))
        assert cl.wait_reply(int(Interface.SIMULATION), 2) == ACK
        t0 = srv.sim.time_s
        wait_for(lambda: srv.sim.time_s > t0 + 1.0, what="time to pass after the poses")
        alive(srv)


class _Broken(Driver):
    """A device whose every entry point raises (a driver bug, not a bad client)."""

    interf = int(Interface.SONAR)  # added as sonar:1
    commands = frozenset({1})

    def data(self) -> Any:
        raise RuntimeError("broken data")

    def before_step(self) -> None:
        raise RuntimeError("broken step")

    def handle_command(self, subtype: int, body: Any) -> None:
        raise RuntimeError("broken command")


def test_a_failing_driver_is_contained_counted_and_logged_rate_limited(
        caplog: pytest.LogCaptureFixture) -> None:
    def add_broken(sim: Any, endpoints: list[Any]) -> None:
        endpoints[0].drivers[(int(Interface.SONAR), 1)] = _Broken(index=1)

    caplog.set_level(logging.INFO)
    with serve(extra=add_broken) as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        cl.send(hw.subscribe(int(Interface.SONAR), 1) + hw.subscribe(P2D))
        assert cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_DEV) == ACK
        cl.send(b"".join(hw.frame(int(Interface.SONAR), 1, int(MsgType.CMD), 1, b"")
                         for _ in range(300)))
        wait_for(lambda: srv.core.counters.internal_errors >= 300, what="300 contained errors")
        wait_for(lambda: srv.driver_errors >= 20 and srv.core.counters.driver_errors >= 1,
                 what="step and data errors")
        # PUSH data still flows for the healthy device
        seen = set()
        for _ in range(200):
            h, _ = cl.read_message()
            seen.add(h[2])
            if P2D in seen:
                break
        assert P2D in seen
        alive(srv)
    lines = [r for r in caplog.records if "broken" in r.getMessage()]
    assert 0 < len(lines) <= 3 * 5 + 3  # three keys, a burst each (one period)


def test_nan_command_flood_is_counted_not_logged_line_by_line(
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    with serve() as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        cl.send(hw.subscribe(P2D))
        assert cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_DEV) == ACK
        cl.send(hw.velocity(math.nan, 0.0) * 5000)
        wait_for(lambda: srv.core.counters.commands_refused >= 5000, what="5000 refusals")
        alive(srv)
    bad = [r for r in caplog.records if "bad message" in r.getMessage()]
    assert len(bad) <= 10


def test_request_flood_is_served_in_budgets_and_another_robot_keeps_its_rounds() -> None:
    with serve("longterm", speedup=0.0, input_budget=16) as srv:
        flooder = hw.RawClient(srv.ports["p1"])
        flood = hw.encode_message(int(Interface.PLAYER), 0, int(MsgType.REQ),
                                  c.PLAYER_REQ_DEVLIST) * 20_000
        with PlayerClient("127.0.0.1", srv.ports["p2"], timeout_s=20.0,
                          read_timeout_s=20.0) as good:
            good.set_datamode(c.PLAYER_DATAMODE_PULL)
            pos = good.subscribe(Position2dProxy)
            flooder.sock.setblocking(False)
            (flood_session,) = [s for s in list(srv.core.sessions.values())
                                if s.endpoint.name == "p1"]
            sent = 0
            rounds = 0
            for _ in range(200):  # bounded: rounds interleaved with the flood
                with suppress(BlockingIOError):
                    sent += flooder.sock.send(flood[sent:sent + (1 << 20)])
                good.read()
                rounds += 1
                flooder.drain(0.0)  # read the flood's replies so it is never cut off
            assert rounds == 200 and pos.state is not None
            assert sent > 0
            assert flood_session.counters.budget_exhausted > 0, \
                "the flood never exceeded a turn's budget"
        flooder.close()
        alive(srv, "p2")


def test_stalled_push_and_pull_clients_are_cut_off_at_their_output_limit(
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING)
    limit = 4 << 20
    with serve(speedup=0.0, output_limit_bytes=limit) as srv:
        push = hw.RawClient(srv.ports["overhead"])
        push.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        # ACCEPT every DATA: nothing is replaced, so an unread queue only grows
        push.send(hw.encode_message(int(Interface.PLAYER), 0, int(MsgType.REQ),
                                    c.PLAYER_REQ_ADD_REPLACE_RULE,
                                    hw.pm.AddReplaceRuleReq(-1, -1, -1, -1, 0))
                  + hw.subscribe(int(Interface.CAMERA)))
        pull = hw.RawClient(srv.ports["robot1"])
        pull.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        pull.send(hw.datamode(c.PLAYER_DATAMODE_PULL) + hw.subscribe(int(Interface.CAMERA))
                  + hw.subscribe(int(Interface.LASER)))
        pull.sock.settimeout(1.0)
        for _ in range(400):  # bounded; the server cuts it off long before
            try:
                pull.send(hw.req_data() * 50)
            except OSError:
                break
            if srv.core.counters.closed_output_limit >= 2:
                break
        wait_for(lambda: srv.core.counters.closed_output_limit >= 2, what="two cut-offs")
        assert push.closed_by_server() and pull.closed_by_server()
        for s in srv.core.sessions.values():
            assert s.queue.nbytes <= limit
        push.close()
        pull.close()
        alive(srv)
    assert any("output buffer limit" in r.getMessage() for r in caplog.records)


def test_an_unread_replace_queue_stays_compact() -> None:
    with serve(speedup=0.0) as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        cl.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        cl.send(hw.subscribe(int(Interface.CAMERA)) + hw.subscribe(P2D))
        sessions = list(srv.core.sessions.values())
        assert len(sessions) == 1
        q = sessions[0].queue
        wait_for(lambda: q.replaced > 1000, timeout_s=60.0, what="1000 replaced DATA")
        assert q.entries_held <= 2 * 64 + 16
        assert q.nbytes <= 2 * 160 * 120 * 3 + 4096  # about one image and one odometry


def test_rules_are_capped_per_connection() -> None:
    with serve(max_rules=8) as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        rule = hw.encode_message(int(Interface.PLAYER), 0, int(MsgType.REQ),
                                 c.PLAYER_REQ_ADD_REPLACE_RULE,
                                 hw.pm.AddReplaceRuleReq(-1, -1, -1, -1, 1))
        replies = []
        for _ in range(12):
            cl.send(rule)
            replies.append(cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_ADD_REPLACE_RULE))
        assert replies == [ACK] * 8 + [NACK] * 4
        assert srv.core.counters.rules_refused == 4


def test_connection_cap_and_incomplete_frame_timeout() -> None:
    with serve(max_connections=3, frame_timeout_s=0.5) as srv:
        port = srv.ports["robot1"]
        held = [hw.RawClient(port) for _ in range(3)]
        extra = socket.create_connection(("127.0.0.1", port), timeout=10.0)
        try:
            extra.settimeout(10.0)
            with suppress(ConnectionResetError):
                assert extra.recv(64) == b""  # closed without a banner
        finally:
            extra.close()
        wait_for(lambda: srv.tcp.refused_connections >= 1, what="a refusal")
        # half of a 4 MiB frame, then nothing: the connection is closed
        held[0].send(hw.frame(int(Interface.PLAYER), 0, int(MsgType.REQ), 1, b"\0" * (2 << 20),
                              size=4 << 20))
        assert held[0].closed_by_server(timeout_s=30.0)
        wait_for(lambda: srv.tcp.frame_timeouts >= 1, what="a frame timeout")
        for h in held:
            h.close()
        wait_for(lambda: srv.tcp.connections == 0, what="connections to close")
        alive(srv)


def test_server_sockets_set_nodelay() -> None:
    with serve() as srv, hw.RawClient(srv.ports["robot1"]) as cl:
        cl.send(hw.subscribe(P2D))
        assert cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_DEV) == ACK
        conns = list(srv.tcp._conns.values())
        assert conns
        for conn in conns:
            assert conn.sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) != 0


def test_laser_set_config_applies_what_the_laser_supports_and_nacks_the_rest() -> None:
    with serve() as srv, PlayerClient("127.0.0.1", srv.ports["robot1"], timeout_s=10.0,
                                      read_timeout_s=10.0) as cl:
        laser = cl.subscribe(LaserProxy)
        full = laser.get_config()
        res = full.resolution
        want = sm.LaserConfig(-math.pi / 4, math.pi / 4, 2 * res, 4.0, full.range_res, 0,
                              full.scanning_frequency)
        got = laser.set_config(want)
        assert got.max_range == pytest.approx(4.0) and got.resolution == pytest.approx(2 * res)
        for _ in range(3):
            cl.read()
        assert len(laser.ranges) == 46 and max(laser.ranges) <= 4.0 + 1e-6
        for bad in (sm.LaserConfig(full.min_angle - res, full.max_angle, res, full.max_range,
                                   full.range_res, 0, full.scanning_frequency),  # wider
                    sm.LaserConfig(full.min_angle, full.max_angle, res / 2, full.max_range,
                                   full.range_res, 0, full.scanning_frequency),  # finer
                    sm.LaserConfig(full.min_angle, full.max_angle, res, 2 * full.max_range,
                                   full.range_res, 0, full.scanning_frequency),  # further
                    sm.LaserConfig(math.nan, full.max_angle, res, full.max_range,
                                   full.range_res, 0, full.scanning_frequency)):
            with pytest.raises(PlayerNack):
                laser.set_config(bad)
        now = laser.get_config()
        assert now.max_range == pytest.approx(4.0) and now.resolution == pytest.approx(2 * res)
        laser.set_config(full)
        for _ in range(2):
            cl.read()
        assert len(laser.ranges) == 181


def _odometry_x(srv: PlayerServer, name: str) -> float:
    return float(srv.sim.get_pose(name)[0])


def test_watchdog_stops_a_robot_whose_client_went_silent() -> None:
    with serve(speedup=20.0, watchdog_s=1.0, world_control=True) as srv, \
            hw.RawClient(srv.ports["robot1"]) as cl:
        cl.send(hw.subscribe(P2D) + hw.subscribe(int(Interface.SIMULATION)))
        assert cl.wait_reply(int(Interface.PLAYER), c.PLAYER_REQ_DEV) == ACK
        cl.send(hw.set_pose2d("robot1", -3.0, -2.0, 0.0))
        assert cl.wait_reply(int(Interface.SIMULATION), 2) == ACK
        cl.send(hw.velocity(0.3, 0.0))
        wait_for(lambda: srv.core.watchdog.stops >= 1, what="the watchdog")
        x1 = _odometry_x(srv, "robot1")
        t1 = srv.sim.time_s
        wait_for(lambda: srv.sim.time_s > t1 + 2.0, what="two more simulated seconds")
        # moved while driven, stands once the watchdog fired (a ramp-down's worth at most)
        assert x1 > -3.0 + 0.1
        assert abs(_odometry_x(srv, "robot1") - x1) < 0.1


def test_lockstep_robots_that_keep_asking_are_never_stopped_and_a_frozen_one_is() -> None:
    from player_server.client import FiducialProxy, SimulationProxy

    with serve(speedup=0.0, lockstep=True, lockstep_clients=2, lockstep_timeout_s=1.0,
               world_control=True, watchdog_s=2.0) as srv:
        stop = threading.Event()
        keeper_rounds = [0]

        def keep_asking() -> None:  # another lockstep participant that stays healthy
            with PlayerClient("127.0.0.1", srv.ports["overhead"], timeout_s=10.0,
                              read_timeout_s=10.0, lockstep=True) as other:
                other.set_datamode(c.PLAYER_DATAMODE_PULL)
                other.subscribe(FiducialProxy)
                for _ in range(20_000):
                    if stop.is_set():
                        return
                    other.read()
                    keeper_rounds[0] += 1

        keeper = threading.Thread(target=keep_asking, daemon=True)
        keeper.start()
        try:
            with PlayerClient("127.0.0.1", srv.ports["robot1"], timeout_s=10.0,
                              read_timeout_s=10.0) as cl:
                cl.set_datamode(c.PLAYER_DATAMODE_PULL)
                pos = cl.subscribe(Position2dProxy)
                cl.subscribe(SimulationProxy).set_pose2d("robot1", -1.0, -2.0, 0.0)
                pos.set_velocity(0.2, 0.0)
                t0 = None
                for _ in range(100):  # 10 simulated seconds at 10 Hz, commanded only once
                    cl.read()
                    t0 = t0 if t0 is not None else cl.data_time_s
                assert cl.data_time_s - t0 > 8.0
                assert srv.core.watchdog.stops == 0
                assert _odometry_x(srv, "robot1") > -1.0 + 1.0 and pos.vx > 0.1
                # now it freezes (no more requests): demoted after the lockstep timeout,
                # then stopped by the watchdog once two simulated seconds pass
                wait_for(lambda: srv.core.watchdog.stops == 1, timeout_s=60.0,
                         what="the watchdog")
                x1 = _odometry_x(srv, "robot1")
                t1 = srv.sim.time_s
                wait_for(lambda: srv.sim.time_s > t1 + 2.0, what="time to pass")
                assert abs(_odometry_x(srv, "robot1") - x1) < 0.1
                assert srv.core.counters.demoted == 1
        finally:
            stop.set()
            keeper.join(30.0)
        assert keeper_rounds[0] > 100


def test_live_fuzz_of_every_hostile_class_leaves_the_server_serving() -> None:
    rng = random.Random(13)
    with serve("simple", speedup=20.0, frame_timeout_s=2.0) as srv:
        port = srv.ports["robot1"]
        gen = hw.hostile_frames(rng, "robot1")
        frames = 0
        for _conn in range(6):
            try:
                with hw.RawClient(port) as cl:
                    cl.sock.settimeout(2.0)
                    for _ in range(500):
                        cl.send(next(gen))
                        frames += 1
                    cl.drain(0.05)
                    # and one frame that claims more than the size limit: closed
                    cl.send(hw.frame(int(Interface.PLAYER), 0, int(MsgType.REQ), 1, b"",
                                     size=c.MAX_MESSAGE_SIZE + 1))
                    assert cl.closed_by_server(10.0)
            except (ConnectionError, OSError):
                pass  # the server may close a connection it no longer trusts
            gen = hw.hostile_frames(rng, "robot1")
        assert frames >= 2500
        assert srv.core.counters.bad_messages > 100
        t0 = srv.sim.time_s
        wait_for(lambda: srv.sim.time_s > t0 + 0.5, what="the simulation to go on")
        assert all(math.isfinite(v) for v in srv.sim.get_pose("robot1"))
        alive(srv)


def test_accept_backs_off_when_file_handles_run_out(tmp_path: Any) -> None:
    import os
    import resource
    import subprocess
    import sys

    log_path = tmp_path / "server.log"
    with open(log_path, "w") as log_file:
        proc = subprocess.Popen(
            [sys.executable, "-m", "player_server.server", "simple", "-p", "0"],
            stdout=subprocess.PIPE, stderr=log_file, text=True)
    try:
        assert proc.stdout is not None
        port = None
        for _ in range(50):
            parts = proc.stdout.readline().split()
            if parts[:1] == ["robot1"] and len(parts) > 1 and parts[1].isdigit():
                port = int(parts[1])
                break
        assert port is not None, "no port reported"
        used = len(os.listdir(f"/proc/{proc.pid}/fd"))
        soft, hard = resource.prlimit(proc.pid, resource.RLIMIT_NOFILE)
        resource.prlimit(proc.pid, resource.RLIMIT_NOFILE, (used + 2, hard))
        clients = []
        for _ in range(12):  # within the listen backlog: each connects, few are accepted
            with suppress(OSError):
                clients.append(socket.create_connection(("127.0.0.1", port), timeout=5.0))
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and "not accepting" not in log_path.read_text():
            time.sleep(0.1)
        time.sleep(2.0)  # let it rest and retry a few times (nothing asserted on time)
        assert proc.poll() is None, "the server died"
        for s in clients:
            s.close()
        resource.prlimit(proc.pid, resource.RLIMIT_NOFILE, (soft, hard))
        with PlayerClient("127.0.0.1", port, timeout_s=20.0) as cl:
            assert cl.devlist()
        text = log_path.read_text()
        assert "not accepting" in text
        # rate-limited: a few lines a period, not one per failed accept
        assert text.count("accept failed") <= 12
    finally:
        child_process.stop(proc)
