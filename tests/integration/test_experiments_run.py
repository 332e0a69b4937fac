"""`murdoch run longterm` end to end: real server, robot processes, multicast auctions."""

from __future__ import annotations

import itertools
import json
import math
import os
import pstats
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from sibling import load_sibling

from experiments import events as ev
from experiments.summary import terminal_state_problems
from player_server.client.connection import PlayerClient
from player_server.client.proxies import LaserProxy, Position2dProxy
from player_server.record.reader import iter_messages

pytestmark = pytest.mark.timeout(240)
child_process = load_sibling(__file__, "child_process.py")


def _murdoch() -> list[str]:
    exe = Path(sys.executable).parent / "murdoch"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "experiments.cli"]


@pytest.fixture(scope="module")
def killed_winner_run(longterm_killed_winner_run: Any
                      ) -> tuple[subprocess.CompletedProcess[str], Path]:
    """A 150-second longterm run whose busy robot is killed at 45 s and restarted at 90 s
    (shared with the twin-run test in test_experiments_repeat.py)."""
    return longterm_killed_winner_run.proc, longterm_killed_winner_run.run


def test_short_longterm_run_with_a_killed_winner(
    killed_winner_run: tuple[subprocess.CompletedProcess[str], Path]
) -> None:
    proc, run = killed_winner_run
    for name in ("config.json", "events.jsonl", "run.mcap", "summary.json", "replay.html",
                 "plots/tasks.png", "plots/battery.png", "plots/allocation.png"):
        assert (run / name).is_file(), name
    config = json.loads((run / "config.json").read_text())
    assert config["seed"] == 4
    cpus = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else set()
    if len(cpus) >= 2:  # the serving thread got a CPU of its own (the default)
        pinned = config["cpu_affinity"]
        assert len(pinned["serving"]) == 1 and pinned["serving"][0] not in pinned["others"]
    events = ev.read_events(run / "events.jsonl")
    # every task ends in exactly one terminal state
    assert not any(terminal_state_problems(events).values())
    summary = json.loads((run / "summary.json").read_text())
    assert summary["sim_time_s"] >= 149.0
    assert summary["tasks"]["introduced"] >= 4
    assert {"announce", "bid", "award"} <= set(summary["messages"]["by_kind"])
    # the robot holding a task was killed; its task went back to auction and to another robot
    (failure,) = [e for e in events if e["kind"] == ev.ROBOT_FAILURE]
    victim = failure["robot"]
    realloc = [e for e in events if e["kind"] == ev.REALLOCATION]
    assert realloc and realloc[0]["from_robot"] == victim
    task = realloc[0]["task"]
    awards = [e["robot"] for e in events if e["kind"] == ev.AWARD and e["task"] == task]
    assert awards[0] == victim and any(r != victim for r in awards[1:])
    assert [e["robot"] for e in events if e["kind"] == ev.ROBOT_RESTART] == [victim]
    assert summary["processes"]["runner"]["peak_rss_bytes"] > 0
    assert "sim 0:02:30" in proc.stdout  # the final progress line
    assert (run / "plots" / "robots.png").is_file()
    # a normal stop is not a connection failure in any robot's log
    for log in (run / "logs").glob("robot-*.log"):
        text = log.read_text(errors="replace")
        assert "receive failed" not in text and "Connection reset" not in text, log.name


def test_the_run_is_recorded_in_run_mcap(
    killed_winner_run: tuple[subprocess.CompletedProcess[str], Path]
) -> None:
    """run.mcap read back with the mcap library's own reader, against events.jsonl."""
    _, run = killed_winner_run
    with (run / "run.mcap").open("rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "murdoch"
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        schema_of = {c.topic: summary.schemas[c.schema_id].name
                     for c in summary.channels.values()}
        counts = {summary.channels[cid].topic: n
                  for cid, n in summary.statistics.channel_message_counts.items()}
        assert summary.statistics.chunk_count >= 1
        assert {c.message_encoding for c in summary.channels.values()} == {"json"}
        messages: dict[str, list[tuple[int, int, dict[str, Any]]]] = {}
        for _schema, channel, msg in reader.iter_messages():
            messages.setdefault(channel.topic, []).append(
                (msg.log_time, msg.publish_time, json.loads(msg.data)))
    robots = [f"p{i}" for i in range(1, 7)]
    assert schema_of["/tf"] == "foxglove.FrameTransforms"
    assert schema_of["/events"] == schema_of["/murdoch"] == "foxglove.Log"
    assert schema_of["/world"] == schema_of["/robots"] == "foxglove.SceneUpdate"
    for r in robots:
        assert schema_of[f"/{r}/sonar"] == "foxglove.LaserScan"
        assert schema_of[f"/{r}/battery"] == "murdoch.Battery"
        assert schema_of[f"/{r}/odometry"] == "murdoch.Odometry"
    assert schema_of["/p1/laser"] == schema_of["/p2/laser"] == "foxglove.LaserScan"
    assert "/p3/laser" not in schema_of  # p3 has no laser
    assert sum(counts.values()) > 1000
    # sensors: two samples per simulated second over 150 s, every robot at the same times
    samples = [t for t, _, _ in messages["/tf"]]
    assert 295 <= len(samples) <= 302
    assert all(b - a == pytest.approx(0.5e9, abs=1e6) for a, b in itertools.pairwise(samples))
    for r in robots:
        for what in ("sonar", "sonar_ranges", "odometry", "battery"):
            assert [t for t, _, _ in messages[f"/{r}/{what}"]] == samples, (r, what)
    for t, published, m in messages["/p2/laser"]:
        assert published == t == m["timestamp"]["sec"] * 10**9 + m["timestamp"]["nsec"]
        assert len(m["ranges"]) == 181 and all(0.0 <= v <= 8.0 for v in m["ranges"])
        assert m["frame_id"] == "p2" and m["start_angle"] == pytest.approx(-math.pi / 2)
    tf = messages["/tf"][-1][2]["transforms"]
    assert {t["child_frame_id"] for t in tf} >= {*robots, "red_ball", "ybox1"}
    assert all(0.0 <= m["percent"] <= 100.0 for _, _, m in messages["/p1/battery"])
    # every event of events.jsonl is a Log message at its simulation time, word for word
    lines = (run / "events.jsonl").read_text().splitlines()
    expected = sorted((round(json.loads(ln)["t"] * 1e9), ln) for ln in lines)
    logged = sorted((t, m["message"]) for topic in ("/events", "/murdoch")
                    for t, _, m in messages[topic])
    assert logged == expected
    assert all(json.loads(m["message"])["kind"] == "message" for _, _, m in messages["/murdoch"])
    assert len(messages["/murdoch"]) == sum(1 for ln in lines if '"kind":"message"' in ln)
    # the static world, and the killed robot's state going to failed and back
    world = {e["id"] for e in messages["/world"][0][2]["entities"]}
    assert {"floor", "wall/north", "charger/dock_sw", "charger/dock_ne"} <= world
    (failure,) = [json.loads(ln) for ln in lines if '"kind":"robot_failure"' in ln]
    states = [(t / 1e9, m["state"]) for t, _, m in messages[f"/{failure['robot']}/state"]]
    assert (failure["t"], "failed") in states
    assert states[-1][1] != "failed"  # restarted at 90 s


def _replay_server(recording: Path, *args: str) -> tuple[subprocess.Popen[str], dict[str, int]]:
    proc = subprocess.Popen([sys.executable, "-m", "player_server.server", "--replay",
                             str(recording), "-p", "0", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    ports: dict[str, int] = {}
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(ports) < 6:
        line = proc.stdout.readline()
        if not line:
            break
        parts = line.split()
        if len(parts) >= 3 and parts[1].isdigit():
            ports[parts[0]] = int(parts[1])
    return proc, ports


def test_player_server_replays_the_recording(
    killed_winner_run: tuple[subprocess.CompletedProcess[str], Path]
) -> None:
    _, run = killed_winner_run
    recorded: dict[str, list[tuple[float, dict[str, Any]]]] = {}
    for rec in iter_messages(run / "run.mcap", topics=["/p2/laser", "/p2/odometry"]):
        recorded.setdefault(rec.topic, []).append((rec.t_s, rec.json()))

    def at(topic: str, t: float) -> dict[str, Any]:
        return [m for ts, m in recorded[topic] if ts <= t + 1e-6][-1]

    server, ports = _replay_server(run / "run.mcap", "--speedup", "2")
    try:
        assert set(ports) == {f"p{i}" for i in range(1, 7)}
        with PlayerClient("127.0.0.1", ports["p2"], timeout_s=10.0, read_timeout_s=10.0,
                          lockstep=False) as client:
            laser = client.subscribe(LaserProxy)
            pos = client.subscribe(Position2dProxy)
            assert len(laser.get_geometry().pose.__slots__) == 6
            assert laser.get_config().max_range == pytest.approx(8.0)
            pos.set_velocity(0.5, 0.0)  # taken and ignored: the recording goes on as it was
            seen = 0
            for _ in range(200):
                client.read()
                if laser.scan is None or pos.state is None:
                    continue
                t = client.data_time_s
                assert t is not None
                assert laser.ranges == pytest.approx(at("/p2/laser", t)["ranges"], abs=1e-3)
                odo = at("/p2/odometry", t)
                assert (pos.x, pos.y, pos.yaw) == pytest.approx(
                    (odo["x"], odo["y"], odo["yaw"]), abs=1e-3)
                seen += 1
                if seen >= 5:
                    break
            assert seen >= 5
        out = subprocess.run([sys.executable, "-m", "player_server.client.print_tool", "-p",
                              str(ports["p1"]), "-c", "2", "laser"],
                             capture_output=True, text=True, timeout=60, check=False)
        assert out.returncode == 0, out.stderr
        assert sum(ln.startswith("#laser(6:0)") for ln in out.stdout.splitlines()) == 2
    finally:
        child_process.stop(server)
    assert server.returncode in (0, -15)


def test_replay_of_what_is_not_a_recording(tmp_path: Path) -> None:
    bad = tmp_path / "events.jsonl"
    bad.write_text('{"t":0.0,"kind":"run_start"}\n')
    for target in (bad, tmp_path):
        proc = subprocess.run([sys.executable, "-m", "player_server.server", "--replay",
                               str(target), "-p", "0"],
                              capture_output=True, text=True, timeout=60, check=False)
        assert proc.returncode == 2 and "player-server:" in proc.stderr, proc.stderr
        assert "Traceback" not in proc.stderr


def test_short_boxpush_run_auctions_pushing_subtasks(boxpush_switched_run: Any) -> None:
    """90 s of boxpush, pusher1 off from 30 s to 60 s (the run is shared with the twin-run
    test in test_experiments_repeat.py, which also shows that profiling changes nothing)."""
    profiles = boxpush_switched_run.profiles
    # each robot wrote a profile of its loop when it stopped
    written = sorted(p.stem for p in profiles.glob("*.prof"))
    assert written == ["pusher1", "pusher2", "watcher"]
    assert pstats.Stats(str(profiles / "watcher.prof")).total_calls > 1000  # type: ignore[attr-defined]
    run = boxpush_switched_run.run
    events = ev.read_events(run / "events.jsonl")
    assert not any(terminal_state_problems(events).values())
    introduced = {e["task"]: e for e in events if e["kind"] == ev.TASK_INTRODUCED}
    awards = {e["task"]: e["robot"] for e in events if e["kind"] == ev.AWARD}
    (watch,) = [t for t, e in introduced.items() if e["task_kind"] == "watch-box"]
    assert awards[watch] == "watcher"
    pushes = [t for t, e in introduced.items() if e["task_kind"].startswith("push-")]
    assert pushes and all(introduced[t]["source"] == "watcher" for t in pushes)
    assert {awards[t] for t in pushes if t in awards} <= {"pusher1", "pusher2"}
    assert any(t in awards for t in pushes)


def test_specialist_and_distance_terms_give_tracking_to_the_camera_only_robots(
    tmp_path: Path,
) -> None:
    out = tmp_path / "runs"
    proc = subprocess.run(
        [*_murdoch(), "run", "longterm", "--until", "150s", "--task-interval", "20",
         "--seed", "4", "--metric", "distance,specialist", "--no-replay", "--no-plots",
         "--out", str(out)],
        capture_output=True, text=True, timeout=220, check=False,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    (run,) = out.iterdir()
    assert json.loads((run / "config.json").read_text())["metric_terms"] == [
        "distance", "specialist"]
    events = ev.read_events(run / "events.jsonl")
    assert not any(terminal_state_problems(events).values())
    kind = {e["task"]: e["task_kind"] for e in events if e["kind"] == ev.TASK_INTRODUCED}
    first_award: dict[str, dict] = {}
    specialist_bid: set[str] = set()
    for e in events:
        if e["kind"] == ev.AWARD:
            first_award.setdefault(e["task"], e)
        elif (e["kind"] == ev.MESSAGE and e["msg_kind"] == "bid"
              and e["sender"] in ("p5", "p6") and e.get("task") not in first_award):
            specialist_bid.add(str(e.get("task")))
    contested = [t for t, k in kind.items() if k == "object-tracking" and t in specialist_bid
                 and t in first_award]
    assert contested, kind
    for task in contested:
        award = first_award[task]
        # a camera-only robot that bid beats every generalist (one spare resource fewer)
        assert award["robot"] in ("p5", "p6"), award
        assert award["bid"] < 0.0  # the specialist term (-6 per spare resource) is in it


def test_the_distance_summed_while_recording_is_the_one_read_back(
    killed_winner_run: tuple[subprocess.CompletedProcess[str], Path]
) -> None:
    """summary.json's distance_m, summed by the runner from each /tf as it was written, is
    exactly what `murdoch report` sums from run.mcap read back."""
    from experiments import rundir as rd
    from experiments.report import distance_driven, world_of

    _, run = killed_winner_run
    summary = json.loads((run / "summary.json").read_text())
    rundir = rd.RunDir(run)
    assert summary["distance_m"]["total"] > 1.0
    assert distance_driven(rundir, world_of(rundir)) == summary["distance_m"]
