"""The line protocol of a host of robots (`behaviors.host`): commands in, status out.

Commands, one a line on the host's standard input:

    start NAME ARG...   start robot NAME with these `murdoch-robot` arguments (shell-quoted)
    kill NAME           cut robot NAME off at once, as a killed process (`behaviors.cut`)

End of input stops every robot as SIGTERM stops a `murdoch-robot` process, and the host
exits. Status, one a line on the host's standard output:

    started NAME        its thread runs
    killed NAME         it is cut off (nothing it does from now on is seen)
    not-running NAME    a kill of a robot that was not running (its exit was told before)
    exited NAME CODE    it ended by itself with this exit code
    refused TEXT        a command line that could not be understood, and why
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass

STATUSES = ("started", "killed", "not-running", "exited", "refused")


class ControlError(ValueError):
    """A command line that is not one of the host's commands."""


@dataclass(frozen=True)
class Start:
    name: str
    args: tuple[str, ...]

    def line(self) -> str:
        return shlex.join(["start", self.name, *self.args])


@dataclass(frozen=True)
class Kill:
    name: str

    def line(self) -> str:
        return shlex.join(["kill", self.name])


Command = Start | Kill


def parse_command(line: str) -> Command:
    try:
        words = shlex.split(line)
    except ValueError as exc:
        raise ControlError(f"{line.strip()!r}: {exc}") from None
    if not words:
        raise ControlError("an empty command line")
    verb, rest = words[0], words[1:]
    if verb == "start" and rest:
        return Start(rest[0], tuple(rest[1:]))
    if verb == "kill" and len(rest) == 1:
        return Kill(rest[0])
    raise ControlError(f"{line.strip()!r}: expected 'start NAME ARG...' or 'kill NAME'")


@dataclass(frozen=True)
class Status:
    what: str
    name: str = ""
    code: int = 0
    text: str = ""

    def line(self) -> str:
        if self.what == "exited":
            return f"exited {self.name} {self.code}"
        if self.what == "refused":
            return f"refused {self.text}"
        return f"{self.what} {self.name}"


def parse_status(line: str) -> Status | None:
    """A status line of the host (None: not one)."""
    what, _, rest = line.strip().partition(" ")
    if what not in STATUSES:
        return None
    if what == "refused":
        return Status(what, text=rest)
    name, _, code = rest.partition(" ")
    if not name:
        return None
    if what == "exited":
        try:
            return Status(what, name, int(code))
        except ValueError:
            return None
    return Status(what, name) if not code else None
