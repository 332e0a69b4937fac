"""The command-line tools: ``player-server WORLD`` and ``player-print``."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from sibling import load_sibling

pytestmark = pytest.mark.timeout(300)

free_ports = load_sibling(__file__, "free_ports.py")
child_process = load_sibling(__file__, "child_process.py")


# how long a server may take to print its port table: seconds idle, but a minute or more on
# one CPU shared with a busy loop and the rest of the suite
START_S = 180.0


@contextmanager
def server_process(*args: str) -> Iterator[dict[str, tuple[int, str]]]:
    proc = subprocess.Popen([sys.executable, "-m", "player_server.server", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    table: dict[str, tuple[int, str]] = {}
    started = time.monotonic()
    try:
        header_seen = False
        while time.monotonic() < started + START_S:
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
        if not table:
            child_process.stop(proc)
            err = proc.stderr.read() if proc.stderr is not None else ""
            pytest.fail(f"the server printed no port table in {time.monotonic() - started:.0f}"
                        f" s (exit code {proc.returncode}): {err[-2000:]}")
        yield table
    finally:
        child_process.stop(proc)


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


def test_player_print_waits_for_a_server_still_starting() -> None:
    """`player-server simple & player-print -p 6665 laser` works as typed: the client retries
    while nothing listens yet, within its -t timeout."""
    port = free_ports.free_port_block()
    printer = subprocess.Popen(
        [sys.executable, "-m", "player_server.client.print_tool", "-p", str(port), "-t", "60",
         "-c", "1", "laser"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    server = None
    try:
        time.sleep(0.5)  # not needed for correctness: gives the client a refusal or two first
        server = subprocess.Popen(
            [sys.executable, "-m", "player_server.server", "simple", "-p", str(port), "-q"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        out, err = printer.communicate(timeout=90)
        assert printer.returncode == 0, err
        assert out.startswith("#laser(6:0)")
    finally:
        for proc in (printer, server):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait(10)


BIN = Path(sys.executable).parent


@pytest.mark.parametrize("command", ["player-server", "player-print", "murdoch-robot", "murdoch"])
def test_help_is_double_dash_help_everywhere(command: str) -> None:
    out = subprocess.run([str(BIN / command), "--help"], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert "--help" in out.stdout
    if command == "murdoch":
        refused = subprocess.run([str(BIN / command), "-h"], capture_output=True, text=True,
                                 timeout=60)
        assert refused.returncode == 2
        assert "No such option '-h'" in refused.stderr
        assert "Try 'murdoch --help' for help" in refused.stderr
    else:
        # -h takes a HOST: Player's habit
        assert "-h HOST" in out.stdout
        bare = subprocess.run([str(BIN / command), "-h"], capture_output=True, text=True,
                              timeout=60)
        assert bare.returncode == 2 and "expected one argument" in bare.stderr


def test_robot_and_server_options_explain_themselves() -> None:
    robot = subprocess.run([str(BIN / "murdoch-robot"), "--help"], capture_output=True,
                           text=True, timeout=60).stdout
    assert "sentry-duty" in robot and "{," not in robot and "''" not in robot
    server = subprocess.run([str(BIN / "player-server"), "--help"], capture_output=True,
                            text=True, timeout=60).stdout
    assert "--fidelity {fast,render}" in server and "render (PyBullet" in " ".join(server.split())
    bad = subprocess.run([str(BIN / "murdoch-robot"), "-p", "1", "--task", "dance"],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "sentry-duty" in bad.stderr


def test_a_port_in_use_is_named_with_a_way_out() -> None:
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = subprocess.run([str(BIN / "player-server"), "simple", "-p", str(port)],
                             capture_output=True, text=True, timeout=60)
    assert out.returncode == 1
    line = out.stderr.strip().splitlines()[-1]
    assert line == (f"player-server: cannot listen on 127.0.0.1: port {port} is already in use "
                    "(another player-server?); give another base port with -p, or -p 0 for "
                    "free ports")


def test_listen_errors_read_as_one_line() -> None:
    import errno

    from player_server.server.listen_errors import describe_listen_error

    busy = OSError(errno.EADDRINUSE, "Address already in use")
    assert "port 6666 is already in use" in describe_listen_error(
        busy, "127.0.0.1", [6665, 6666], in_use=lambda h, p: p == 6666)
    assert "a port in 6665-6666 is already in use" in describe_listen_error(
        busy, "127.0.0.1", [6665, 6666], in_use=lambda h, p: False)
    denied = OSError(errno.EACCES, "Permission denied")
    assert describe_listen_error(denied, "127.0.0.1", [80]) == (
        "cannot listen on 127.0.0.1: Permission denied")


def _listening_addresses(port: int) -> set[str]:
    """Local addresses (hex, as /proc writes them) of TCP sockets listening on `port`."""
    out = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            rows = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            cols = row.split()
            addr, hex_port = cols[1].rsplit(":", 1)
            if int(hex_port, 16) == port and cols[3] == "0A":  # LISTEN
                out.add(addr)
    return out


@pytest.mark.parametrize("bind", [(), ("--bind", "127.0.0.1")])
def test_the_server_listens_on_loopback_unless_told_otherwise(bind: tuple[str, ...]) -> None:
    with server_process("worlds/longterm.toml", "-p", "0", "--speedup", "0", "-q",
                        *bind) as table:
        assert len(table) == 7
        for port, _ in table.values():
            assert _listening_addresses(port) == {"0100007F"}
        port = next(iter(table.values()))[0]
        done = player_print("-h", "127.0.0.1", "-p", str(port), "-c", "1", "position2d")
        assert done.returncode == 0, done.stderr
