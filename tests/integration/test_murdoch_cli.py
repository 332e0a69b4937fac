"""`murdoch listen` and `murdoch announce` as a user runs them, against bidder processes."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from murdoch.multicast import MulticastConfig


def free_config() -> MulticastConfig:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return MulticastConfig(group=f"239.255.{(port >> 8) & 0xFF}.{port & 0xFF or 1}", port=port)


def murdoch_command() -> list[str]:
    script = Path(sys.executable).with_name("murdoch")
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "from experiments.cli import main; main()"]


@pytest.fixture
def config() -> Iterator[MulticastConfig]:
    yield free_config()


def network(config: MulticastConfig) -> list[str]:
    return ["--group", config.group, "--port", str(config.port)]


@pytest.mark.timeout(60)
def test_announce_prints_the_outcome_and_listen_decodes_the_traffic(
    config: MulticastConfig,
) -> None:
    procs = []
    try:
        for name, score in (("cli-b1", 1.0), ("cli-b2", 2.0)):
            proc = subprocess.Popen(
                [sys.executable, "-m", "murdoch.sample_bidder", "--name", name, "--score",
                 str(score), "--lifetime", "30", "--quiet", *network(config)],
                stdout=subprocess.PIPE, text=True)
            procs.append(proc)
        listener = subprocess.Popen(
            [*murdoch_command(), "listen", "--json", "--duration", "25",
             "--subjects", "camera,mobile,idle", *network(config)],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        procs.append(listener)
        assert listener.stderr is not None
        assert listener.stderr.readline().startswith("listening on")
        for proc in procs[:2]:
            assert proc.stdout is not None and "ready" in proc.stdout.readline()
        done = subprocess.run(
            [*murdoch_command(), "announce", "object-tracking", "--subjects", "camera,mobile",
             "--duration", "0.3", "--param", "colour=red", "--bid-window", "1.0",
             "--wait", "20", *network(config)],
            capture_output=True, text=True, timeout=40)
        assert done.returncode == 0, done.stderr
        result = json.loads(done.stdout.strip().splitlines()[-1])
        assert (result["status"], result["winner"], result["attempts"]) == (
            "completed", "cli-b2", 1)
        assert "award" in done.stdout
        nobody = subprocess.run(
            [*murdoch_command(), "announce", "monitor-object", "--subjects", "overhead-camera",
             "--bid-window", "0.2", "--quiet", *network(config)],
            capture_output=True, text=True, timeout=40)
        assert nobody.returncode == 1
        result = json.loads(nobody.stdout.strip().splitlines()[-1])
        assert result["status"] == "unachievable" and "no capable agent" in result["reason"]
        listener.send_signal(signal.SIGINT)
        out, _ = listener.communicate(timeout=30)
        assert listener.returncode == 0
        records = [json.loads(line) for line in out.splitlines()]
        # with --subjects only what such a robot would receive is shown: one announcement
        assert [r["kind"] for r in records] == ["announce"]
        assert records[0]["fields"]["params"] == {"colour": "red"}
        assert records[0]["subjects"] == ["camera", "idle", "mobile"]
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.terminate()
            proc.wait(timeout=10)


@pytest.mark.timeout(30)
def test_listen_without_a_filter_shows_every_kind(config: MulticastConfig) -> None:
    listener = subprocess.Popen(
        [*murdoch_command(), "listen", "--duration", "15", "--count", "2", *network(config)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert listener.stderr is not None
        assert listener.stderr.readline().startswith("listening on")
        subprocess.run(
            [*murdoch_command(), "announce", "cleanup", "--subjects", "bumper",
             "--bid-window", "0.2", "--quiet", *network(config)],
            capture_output=True, text=True, timeout=20, check=False)
        out, _ = listener.communicate(timeout=20)
    finally:
        if listener.poll() is None:
            listener.terminate()
        listener.wait(timeout=10)
    lines = out.splitlines()
    assert " announce " in lines[0] and 'name="cleanup"' in lines[0]
    assert " award " in lines[1] and 'reason="no capable agent bid"' in lines[1]


@pytest.mark.timeout(90)
def test_the_same_auction_runs_over_zenoh_through_a_hub() -> None:
    pytest.importorskip("zenoh", reason="the zenoh extra (eclipse-zenoh) is not installed")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        endpoint = f"tcp/127.0.0.1:{probe.getsockname()[1]}"
    net = ["--transport", "zenoh", "--zenoh-endpoint", endpoint]
    procs = []
    try:
        # the listener is the team's hub; everyone else connects to it
        listener = subprocess.Popen(
            [*murdoch_command(), "listen", "--json", "--duration", "40", "--zenoh-hub", *net],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        procs.append(listener)
        assert listener.stderr is not None
        assert listener.stderr.readline().startswith(f"listening on zenoh as the hub on {endpoint}")
        for name, score in (("zb1", 1.0), ("zb2", 2.0)):
            proc = subprocess.Popen(
                [sys.executable, "-m", "murdoch.sample_bidder", "--name", name, "--score",
                 str(score), "--lifetime", "40", "--quiet", *net],
                stdout=subprocess.PIPE, text=True)
            procs.append(proc)
        for proc in procs[1:]:
            assert proc.stdout is not None and "ready" in proc.stdout.readline()
        done = subprocess.run(
            [*murdoch_command(), "announce", "object-tracking", "--subjects", "camera,mobile",
             "--duration", "0.3", "--bid-window", "1.0", "--wait", "30", *net],
            capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        result = json.loads(done.stdout.strip().splitlines()[-1])
        assert (result["status"], result["winner"]) == ("completed", "zb2")
        listener.send_signal(signal.SIGINT)
        out, _ = listener.communicate(timeout=30)
        kinds = [json.loads(line)["kind"] for line in out.splitlines()]
        assert kinds[0] == "announce" and kinds.count("bid") == 2 and "award" in kinds
        assert "report" in kinds
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.terminate()
            proc.wait(timeout=10)


def test_a_zenoh_endpoint_off_loopback_is_refused_by_name() -> None:
    done = subprocess.run(
        [*murdoch_command(), "listen", "--duration", "1", "--transport", "zenoh",
         "--zenoh-endpoint", "tcp/192.0.2.1:7447"],
        capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "--zenoh-endpoint" in done.stderr and "only 127.0.0.1" in done.stderr
    assert "Traceback" not in done.stderr
