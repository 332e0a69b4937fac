"""Robots K to a process: grouping into hosts, the host's line protocol, cutting a robot off,
and the options checked before a run starts (`murdoch run --robots-per-process`)."""

from __future__ import annotations

import io
import socket
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner

from behaviors.cut import AbortableClient, Cut
from behaviors.host import RobotThreads, serve_commands
from behaviors.host_control import (
    ControlError,
    Kill,
    Start,
    Status,
    parse_command,
    parse_status,
)
from experiments.plugin import Fault
from experiments.registry import experiments
from experiments.robot_hosts import group_robots, robots_per_process
from experiments.run_checks import RunSetupError
from experiments.run_cli import run
from experiments.run_extras import RunExtras
from experiments.run_parts import RunSettings, _check_placement
from experiments.supervisor import BusPlace, robot_process
from player_server.client import PlayerConnectionError

ROBOTS = ["p1", "p2", "p3", "p4", "p5", "p6", "desktop"]


def test_robots_are_grouped_in_order_k_to_a_host() -> None:
    assert group_robots(ROBOTS, 3) == [("p1", "p2", "p3"), ("p4", "p5", "p6"), ("desktop",)]
    assert group_robots(ROBOTS, 1) == [(n,) for n in ROBOTS]
    assert group_robots(ROBOTS, 10) == [tuple(ROBOTS)]
    hundred = [f"r{i}" for i in range(100)]
    assert [len(g) for g in group_robots(hundred, 10)] == [10] * 10
    assert [len(g) for g in group_robots(hundred, 30)] == [30, 30, 30, 10]
    with pytest.raises(ValueError, match="at least 1"):
        group_robots(ROBOTS, 0)


def test_command_lines_round_trip_with_quoted_arguments() -> None:
    start = Start("p3", ("-p", "6667", "--events", "/runs/a b/p3.events.jsonl"))
    assert parse_command(start.line()) == start
    assert parse_command(Kill("p3").line()) == Kill("p3")
    assert parse_command("start p1") == Start("p1", ())
    for bad in ("", "kill", "kill p1 p2", "stop p1", "start", "start 'p1"):
        with pytest.raises(ControlError):
            parse_command(bad)


def test_status_lines_round_trip_and_other_lines_are_not_status() -> None:
    for status in (Status("started", "p1"), Status("killed", "p1"),
                   Status("not-running", "p1"), Status("exited", "p1", 2),
                   Status("refused", text="'stop p1': expected ...")):
        assert parse_status(status.line()) == status
    for other in ('{"ready": {"robot": "p1"}}', "exited p1 x", "started", "killed p1 3", ""):
        assert parse_status(other) is None


def test_a_cut_robot_writes_nothing_more_and_what_it_holds_is_aborted() -> None:
    cut = Cut()
    out = io.StringIO()
    stream = cut.gate(out)
    aborted: list[str] = []
    cut.hold(lambda: aborted.append("client"))
    stream.write("one\n")
    cut.cut()
    stream.write("two\n")
    stream.flush()
    cut.cut()  # once is enough
    cut.hold(lambda: aborted.append("late"))  # held after the cut: aborted at once
    assert out.getvalue() == "one\n"
    assert aborted == ["client", "late"]
    assert cut.is_cut


def test_a_client_cut_off_while_it_connects_drops_the_connection_once_it_is_made() -> None:
    """The cut lands while the socket is still being connected (no socket held yet to
    shut down): the connection is dropped as soon as it is made, not after the handshake's
    timeout, and the server sees it closed without a word."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        listener.settimeout(10.0)
        client = AbortableClient("127.0.0.1", listener.getsockname()[1], timeout_s=600.0)
        client.abort()  # before connect() has a socket to abort
        failed: list[BaseException] = []

        def connect() -> None:
            try:
                client.connect()  # the banner never comes: only the drop can end this
            except Exception as exc:
                failed.append(exc)

        thread = threading.Thread(target=connect, daemon=True)
        thread.start()
        conn, _ = listener.accept()
        conn.settimeout(30.0)
        with conn:
            assert conn.recv(64) == b""
        thread.join(30.0)
        assert [type(e) for e in failed] == [PlayerConnectionError]
        assert not client.connected


def test_a_host_tells_what_it_cannot_do_and_goes_on() -> None:
    told: list[Status] = []
    robots = RobotThreads(told.append)
    lines = ["kill p1\n", "dance p1\n", "\n", "start p2 --no-such-option\n"]
    serve_commands(lines, robots, told.append)
    assert told[0] == Status("not-running", "p1")
    assert told[1].what == "refused" and "dance p1" in told[1].text
    assert told[2] == Status("exited", "p2", 2)  # arguments murdoch-robot refuses
    assert robots.names() == []


def _settings(**kw: object) -> RunSettings:
    base: dict[str, object] = dict(
        experiment=experiments()["longterm"], world_name="longterm", speedup=0.0, meshcat=False,
        out=Path("/o"), kills=(), restarts=(), replay=False, pipelined=True, robot_nice=0,
        pin_cpus=False, key="k", trails=0, lasers=False, record=False, record_rate_hz=2.0,
        metric_terms=(), extras=RunExtras())
    base.update(kw)
    return RunSettings(**base)  # type: ignore[arg-type]


@pytest.mark.parametrize(("kw", "message"), [
    ({"robots_per_process": 0}, "at least 1"),
    ({"robots_per_process": 2.5}, "whole number"),
    ({"robots_per_process": 3, "transport": "zenoh", "placements": (("p1", ("ssh", "h")),)},
     "--place"),
    ({"robots_per_process": 3, "extras": RunExtras(faults=(Fault(60.0, "freeze", "p1"),))},
     "cannot be paused alone"),
])
def test_robots_per_process_is_checked_before_the_run(kw: dict[str, object],
                                                      message: str) -> None:
    with pytest.raises(RunSetupError, match=message):
        _check_placement(_settings(**kw), set(ROBOTS))


def test_one_robot_per_process_and_pausing_as_before() -> None:
    _check_placement(_settings(), set(ROBOTS))
    _check_placement(_settings(extras=RunExtras(faults=(Fault(60.0, "freeze", "p1"),))),
                     set(ROBOTS))


@pytest.mark.parametrize("text", ["0", "-1", "2.5", "many", "", "\u00b2"])
def test_murdoch_run_refuses_a_count_below_one_or_not_a_count(text: str) -> None:
    result = CliRunner().invoke(run, ["longterm", "--robots-per-process", text])
    assert result.exit_code == 2
    assert "--robots-per-process" in result.output and "auto" in result.output


def test_auto_runs_the_team_as_one_host_per_cpu_left_to_the_robots() -> None:
    # two CPUs: one for the serving thread, one host for the robots (at most 100 to a host)
    assert robots_per_process(None, 7, placed=False, pausing=False) == 7  # longterm
    assert robots_per_process(None, 3, placed=False, pausing=False, cpus=2) == 3  # boxpush
    assert robots_per_process(None, 1, placed=False, pausing=False, cpus=2) == 1
    assert robots_per_process(None, 17, placed=False, pausing=False, cpus=2) == 17
    assert robots_per_process(None, 101, placed=False, pausing=False, cpus=2) == 100  # swarm100
    assert robots_per_process(None, 101, placed=False, pausing=False, cpus=1) == 100
    # more CPUs: the team spread evenly over one host per CPU left to the robots
    assert robots_per_process(None, 101, placed=False, pausing=False, cpus=5) == 26
    assert robots_per_process(None, 1000, placed=False, pausing=False, cpus=4) == 100
    assert robots_per_process(None, 7, placed=False, pausing=False, cpus=4) == 3
    assert robots_per_process(None, 7, placed=False, pausing=False, cpus=8) == 1
    # a robot placed elsewhere or paused alone needs its own process
    assert robots_per_process(None, 101, placed=True, pausing=False) == 1
    assert robots_per_process(None, 101, placed=False, pausing=True) == 1
    # a number given is taken as it is
    assert robots_per_process(1, 101, placed=False, pausing=False) == 1
    assert robots_per_process(3, 7, placed=False, pausing=False) == 3


def test_auto_is_allowed_with_places_and_pauses() -> None:
    _check_placement(_settings(robots_per_process=None, transport="zenoh",
                               placements=(("p1", ("ssh", "h")),)), set(ROBOTS))
    _check_placement(_settings(robots_per_process=None, extras=RunExtras(
        faults=(Fault(60.0, "freeze", "p1"),))), set(ROBOTS))


def test_a_host_is_given_the_arguments_of_the_robots_process() -> None:
    spec = robot_process("p1", world="longterm", bus=BusPlace(mcast_port=5000), seed=1,
                         logs=Path("/l"), metric_terms=(), lockstep=True, read_timeout_s=60.0)
    argv = spec.argv(port=6665, instance=2)
    args = spec.arguments(port=6665, instance=2)
    assert argv == [*spec.command, *args]
    assert args[:2] == ["-p", "6665"] and args[args.index("--instance") + 1] == "2"
