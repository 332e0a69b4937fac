"""Headless Chromium for the browser tests: screenshots, and the state a page reports.

The viewer's pages (the live view and replay.html) write what they show into
``<pre id="murdoch-state">`` as JSON (`player_server/viz/overlay.js`); `page_state` loads a
page in a fresh headless Chromium, lets it run for a bounded virtual time and reads that back.
"""

from __future__ import annotations

import contextlib
import html
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
         "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--disable-extensions",
         "--hide-scrollbars")
_STATE = re.compile(r'<pre id="murdoch-state">(.*?)</pre>', re.S)


def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        found = shutil.which(name)
        if found:
            return found
    return None


def require_chromium() -> str:
    exe = chromium()
    if exe is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("headless Chromium is required under CI but was not found")
        pytest.skip("headless Chromium not installed (apt-get install chromium)")
    return exe


class Profiles:
    """A fresh profile directory for each browser started (under a test's tmp_path)."""

    def __init__(self, root: Path) -> None:
        self._root = root
        self._n = itertools.count()

    def next(self) -> Path:
        return self._root / f"profile{next(self._n)}"


def _command(exe: str, profile: Path, size: tuple[int, int], budget_ms: int) -> list[str]:
    return [exe, *FLAGS, f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}",
            f"--virtual-time-budget={budget_ms}"]


def screenshot_commands(exe: str, jobs: Sequence[tuple[str, Path]], profiles: Profiles, *,
                        size: tuple[int, int] = (1024, 768), budget_ms: int = 500
                        ) -> list[list[str]]:
    return [[*_command(exe, profiles.next(), size, budget_ms), f"--screenshot={png}", url]
            for url, png in jobs]


def screenshots(exe: str, jobs: Sequence[tuple[str, Path]], profiles: Profiles, *,
                size: tuple[int, int] = (1024, 768), budget_ms: int = 500,
                timeout_s: float = 300.0, nice: int = 0, attempts: int = 1) -> None:
    """Render each (url, png) pair, in parallel (`nice` as for `page_state`). On a starved
    CPU headless Chromium now and then stops, idle, before it writes the picture: browsers
    still running after `timeout_s` are killed and all started again, `attempts` times in
    all, before `TimeoutExpired` is raised."""
    for attempt in range(1, attempts + 1):
        procs = [_start(cmd, nice, stdout=subprocess.DEVNULL)
                 for cmd in screenshot_commands(exe, jobs, profiles, size=size,
                                                budget_ms=budget_ms)]
        try:
            for p in procs:
                assert p.wait(timeout=timeout_s) == 0
            return
        except subprocess.TimeoutExpired:
            if attempt == attempts:
                raise
        finally:
            for p in procs:
                _end(p)


def page_state(exe: str, url: str, profiles: Profiles, *, size: tuple[int, int] = (1400, 900),
               budget_ms: int = 2000, timeout_s: float = 300.0, nice: int = 0
               ) -> dict[str, Any]:
    """The JSON a viewer page wrote into #murdoch-state after `budget_ms` of virtual time;
    the browser runs `nice` steps from this process's niceness, where it is allowed to.
    A browser that takes longer than `timeout_s` is killed and `TimeoutExpired` raised."""
    proc = _start([*_command(exe, profiles.next(), size, budget_ms), "--dump-dom", url], nice,
                  stdout=subprocess.PIPE)
    try:
        raw, _ = proc.communicate(timeout=timeout_s)
    finally:
        _end(proc)
    out = raw.decode("utf-8", "replace")
    m = _STATE.search(out)
    assert m is not None and m.group(1).strip(), f"no page state in {url} ({len(out)} bytes)"
    state: dict[str, Any] = json.loads(html.unescape(m.group(1)))
    return state


def _start(cmd: list[str], nice: int, stdout: int) -> subprocess.Popen[bytes]:
    # a process group of its own (not a session: that would take it out of this one's share
    # of the CPU), so that a browser that runs out of time is stopped with its renderer and
    # GPU processes, not only the one started here
    return subprocess.Popen(cmd, stdout=stdout, stderr=subprocess.DEVNULL, process_group=0,
                            preexec_fn=(lambda: _renice(nice)) if nice else None)


def _end(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()


def _renice(steps: int) -> None:
    # a higher priority needs root (CAP_SYS_NICE); without it the browser keeps this one
    with contextlib.suppress(PermissionError):
        os.nice(steps)


def overlapping(rects: Mapping[str, Sequence[float]]) -> list[tuple[str, str]]:
    """Pairs of (left, top, width, height) rectangles that overlap."""
    out = []
    for (a, ra), (b, rb) in itertools.combinations(sorted(rects.items()), 2):
        if (ra[0] < rb[0] + rb[2] and rb[0] < ra[0] + ra[2]
                and ra[1] < rb[1] + rb[3] and rb[1] < ra[1] + ra[3]):
            out.append((a, b))
    return out


def pose_at(frames: Iterable[Mapping[str, Any]], t: float, body: str) -> tuple[float, float]:
    """A body's (x, y) at time `t`, linear between the recorded frames around it (before the
    first frame: the first frame's)."""
    before = after = None
    for f in frames:
        if body not in f["bodies"]:
            continue
        if f["t"] <= t:
            before = f
        elif after is None:
            after = f
            break
    if before is None:
        before = after
    assert before is not None, f"no pose of {body} in the recording"
    x0, y0 = before["bodies"][body][:2]
    if after is None or after["t"] == before["t"]:
        return float(x0), float(y0)
    x1, y1 = after["bodies"][body][:2]
    a = (t - before["t"]) / (after["t"] - before["t"])
    return float(x0 + a * (x1 - x0)), float(y0 + a * (y1 - y0))
