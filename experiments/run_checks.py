"""What `murdoch run` checks before anything starts, and the one line it prints instead of a
traceback when the world, the output directory or the disk lets it down.

Every check raises `RunSetupError` whose text is a single line naming the option, file or
directory, what was expected and what was found; the command prints it and exits with
`RunSetupError.exit_code` (2, like any usage error). Nothing here starts a process.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

BUSY = "busy"  # --kill busy@T: the robot holding a task at T


class RunSetupError(Exception):
    """A problem found before (or while writing) a run, as one line for the user."""

    exit_code = 2


def _duration(seconds: float) -> str:
    if seconds >= 3600 and seconds % 3600 == 0:
        return f"{seconds / 3600:g}h"
    if seconds >= 60 and seconds % 60 == 0:
        return f"{seconds / 60:g}m"
    return f"{seconds:g}s"


def load_run_world(name: str) -> Any:
    """The world of a run (a bundled name, a .toml or .world path) or `RunSetupError`."""
    from worlds import WorldError, load_world, world_path

    path = Path(name)
    try:
        if path.suffix in (".toml", ".world") or os.sep in name:
            if not path.is_file():
                raise RunSetupError(f"--world {name}: no such world file")
            return load_world(path)
        return load_world(world_path(name))
    except WorldError as exc:
        raise RunSetupError(str(exc).splitlines()[0]) from exc
    except FileNotFoundError as exc:
        raise RunSetupError(f"--world {name}: {exc}") from exc
    except OSError as exc:
        raise RunSetupError(f"--world {name}: cannot read it: {exc.strerror or exc}") from exc


def describe_os_error(exc: OSError, what: str) -> str:
    """One line for an OSError met while doing `what` (e.g. "writing runs/x/events.jsonl")."""
    code = exc.errno
    if code == errno.ENOSPC:
        reason = "no space left on the device"
    elif code == errno.EROFS:
        reason = "the file system is read-only"
    elif code in (errno.EACCES, errno.EPERM):
        reason = "permission denied"
    elif code == errno.ENOENT:
        reason = "no such file or directory"
    elif code == errno.ENOTDIR:
        reason = "a part of the path is a file, not a directory"
    elif code == errno.EDQUOT:
        reason = "disk quota exceeded"
    else:
        reason = exc.strerror or str(exc)
    where = f" ({exc.filename})" if exc.filename and str(exc.filename) not in what else ""
    return f"{what}: {reason}{where}"


def check_out_dir(out: Path) -> None:
    """Make sure run directories can be created and written under `out` (created if needed),
    by writing and removing a probe file. Leaves nothing behind but `out` itself."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise RunSetupError(f"--out {out}: is a file, expected a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".murdoch-write-probe-{os.getpid()}"
        try:
            with probe.open("wb") as f:
                f.write(b"\0" * 4096)
                f.flush()
                os.fsync(f.fileno())
        finally:
            probe.unlink(missing_ok=True)
    except OSError as exc:
        raise RunSetupError(describe_os_error(exc, f"--out {out}: cannot write there")) from exc


def check_schedule(
    *,
    robots: Sequence[str],
    duration_s: float,
    kills: Sequence[tuple[str, float]] = (),
    restarts: Sequence[tuple[str, float]] = (),
    switch_offs: Sequence[tuple[str, float]] = (),
    switch_ons: Sequence[tuple[str, float]] = (),
    world: str = "",
) -> None:
    """Reject failure-injection options that would be silently ignored: an unknown robot, a
    time at or past the end of the run, a restart with no kill before it (a switch-on with no
    switch-off). `robots` are the world's robot names; ``busy`` is also accepted for --kill and
    --restart."""
    names = list(robots)
    listed = ", ".join(names)
    in_world = f" in world {world}" if world else ""
    options = (("--kill", kills, True), ("--restart", restarts, True),
               ("--switch-off", switch_offs, False), ("--switch-on", switch_ons, False))
    for option, items, busy_ok in options:
        for robot, t in items:
            given = f"{option} {robot}@{_duration(t)}"
            if robot not in names and not (busy_ok and robot == BUSY):
                extra = f" or {BUSY}" if busy_ok else ""
                raise RunSetupError(f"{given}: no robot {robot!r}{in_world} "
                                    f"(robots: {listed}{extra})")
            if t < 0:
                raise RunSetupError(f"{given}: the time must not be negative")
            if t >= duration_s:
                raise RunSetupError(
                    f"{given}: {_duration(t)} is at or past the end of the run "
                    f"({_duration(duration_s)} simulated); give a longer --until")
    for first, then, a, b in ((kills, restarts, "--restart", "--kill"),
                              (switch_offs, switch_ons, "--switch-on", "--switch-off")):
        for robot, t in then:
            if not any(r == robot and t0 < t for r, t0 in first):
                raise RunSetupError(f"{a} {robot}@{_duration(t)}: no {b} {robot} before it")


MESHCAT_SPEEDUP = 10.0  # a watched run: 10 simulated seconds per wall second
LIVE_RATE_HZ = 10.0  # frames per wall second sent to the live view (--live-rate)


def effective_speedup(given: float | None, meshcat: bool) -> float:
    """--speedup as given; when not given, 0 (as fast as possible, lockstep), or
    `MESHCAT_SPEEDUP` for a run watched live (20 simulated minutes in 2 wall minutes)."""
    if given is not None:
        return given
    return MESHCAT_SPEEDUP if meshcat else 0.0
