"""Robots on another host: a run whose robot p2 lives in a network namespace of its own.

Two namespaces joined by a veth pair stand for two hosts; their addresses exist only inside
them (the machine's own interfaces are untouched). The runner, the Player server and the
Zenoh hub bind the "server host's" address; p2 is started through `ip netns exec` and reaches
them over the veth link only. Needs root and network namespaces; skipped otherwise.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from experiments import events as ev

pytest.importorskip("zenoh", reason="the zenoh extra (eclipse-zenoh) is not installed")
pytestmark = pytest.mark.timeout(300)

SERVER_ADDR = "10.219.0.1"
ROBOT_ADDR = "10.219.0.2"


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True, timeout=30)


@pytest.fixture
def two_hosts() -> Iterator[tuple[str, str]]:
    if shutil.which("ip") is None or os.geteuid() != 0:
        pytest.skip("network namespaces need the ip command and root")
    tag = f"{os.getpid() % 100000}"
    server, robot = f"m19s{tag}", f"m19r{tag}"
    made: list[str] = []
    try:
        for ns in (server, robot):
            _ip("netns", "add", ns)
            made.append(ns)
    except subprocess.CalledProcessError as exc:
        for ns in made:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)
        pytest.skip(f"network namespaces are not available here: {exc.stderr.strip()}")
    try:
        # the veth pair is created inside the server namespace and one end moved on: the
        # machine's own namespace never holds either end
        _ip("-n", server, "link", "add", f"vs{tag}", "type", "veth", "peer", "name", f"vr{tag}")
        _ip("-n", server, "link", "set", f"vr{tag}", "netns", robot)
        for ns, dev, addr in ((server, f"vs{tag}", SERVER_ADDR), (robot, f"vr{tag}", ROBOT_ADDR)):
            _ip("-n", ns, "addr", "add", f"{addr}/30", "dev", dev)
            _ip("-n", ns, "link", "set", dev, "up")
            _ip("-n", ns, "link", "set", "lo", "up")
        yield server, robot
    finally:
        for ns in made:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


def test_a_robot_in_another_namespace_takes_part_over_zenoh(
    two_hosts: tuple[str, str], tmp_path: Path,
) -> None:
    server, robot = two_hosts
    out = tmp_path / "runs"
    proc = subprocess.run(
        ["ip", "netns", "exec", server, *_murdoch(), "run", "longterm", "--until", "60s",
         "--task-interval", "10", "--seed", "3", "--no-replay", "--no-plots", "--no-pin-cpus",
         "--transport", "zenoh", "--bind", SERVER_ADDR,
         "--place", f"p2=ip netns exec {robot}", "--out", str(out)],
        capture_output=True, text=True, timeout=280, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    (run,) = out.iterdir()
    config = json.loads((run / "config.json").read_text())
    assert (config["transport"], config["bind"]) == ("zenoh", SERVER_ADDR)
    placed = {p["name"]: p for p in config["processes"]}
    assert placed["p2"]["launch"] == ["ip", "netns", "exec", robot]
    assert placed["p1"]["launch"] == []
    args = placed["p2"]["args"]
    assert args[args.index("-h") + 1] == SERVER_ADDR
    assert args[args.index("--zenoh-endpoint") + 1].startswith(f"tcp/{SERVER_ADDR}:")
    events = ev.read_events(run / "events.jsonl")
    # the lockstep clock advanced only because p2's Player session kept pace over the veth
    # link; its MURDOCH datagrams reached the runner's hub the same way
    assert events[-1]["t"] >= 59.0
    senders = {e["sender"] for e in events if e["kind"] == ev.MESSAGE}
    assert "p2" in senders, sorted(senders)
    log = (run / "logs" / "robot-p2.log").read_text(errors="replace")
    assert "cannot" not in log, log[-2000:]


def test_placing_robots_elsewhere_on_the_multicast_bus_is_refused(tmp_path: Path) -> None:
    proc = subprocess.run(
        [*_murdoch(), "run", "longterm", "--until", "10s", "--place", "p2=ssh lab-2",
         "--out", str(tmp_path / "runs")],
        capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode != 0
    assert "need --transport zenoh" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())
