"""The command-line tools: ``player-server WORLD`` and ``player-print``."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

pytestmark = pytest.mark.timeout(90)


@contextmanager
def server_process(*args: str) -> Iterator[dict[str, tuple[int, str]]]:
    proc = subprocess.Popen([sys.executable, "-m", "player_server.server", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    table: dict[str, tuple[int, str]] = {}
    try:
        deadline = time.monotonic() + 60
        header_seen = False
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            parts = line.strip().split(maxsplit=2)
            if parts[:3] == ["robot", "port", "devices"]:
                header_seen = True
                continue
            if header_seen and len(parts) == 3 and parts[1].isdigit():
                table[parts[0]] = (int(parts[1]), parts[2].strip())
            elif header_seen and table:
                break
            if header_seen and len(table) >= 7:
                break
        yield table
    finally:
        proc.terminate()
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


def player_print(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "player_server.client.print_tool", *args],
                          capture_output=True, text=True, timeout=60)


def test_longterm_serves_every_robot_and_player_print_shows_scans() -> None:
    with server_process("worlds/longterm.toml", "-p", "0", "--speedup", "0", "-q") as table:
        assert set(table) == {"p1", "p2", "p3", "p4", "p5", "p6", "desktop"}
        assert "laser:0" in table["p2"][1] and "gripper:0" in table["p4"][1]
        assert table["desktop"][1] == "camera:0, blobfinder:0, fiducial:0, simulation:0"
        out = player_print("-p", str(table["p2"][0]), "-c", "2", "laser")
        assert out.returncode == 0, out.stderr
        scans = [ln for ln in out.stdout.splitlines() if ln.startswith("#laser(6:0)")]
        assert len(scans) == 2
        stamps = [float(s.split(" - ")[1]) for s in scans]
        assert stamps[1] > stamps[0]
        ranges = next(ln for ln in out.stdout.splitlines() if ln.startswith("ranges:"))
        assert len(ranges.split()) == 1 + 181
        out = player_print("-p", str(table["p1"][0]), "-i", "2", "-c", "1", "laser")
        assert out.returncode == 1 and "refused" in out.stderr


def test_bad_world_is_reported() -> None:
    proc = subprocess.run([sys.executable, "-m", "player_server.server", "no/such/world.toml"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "player-server:" in proc.stderr


def test_player_print_help_and_connection_error() -> None:
    out = player_print("--help")
    assert out.returncode == 0 and "-h HOST" in out.stdout
    out = player_print("-p", "1", "-t", "1", "sonar")
    assert out.returncode == 1 and "cannot connect" in out.stderr
