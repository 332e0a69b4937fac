"""What a device driver is: the server's view of one Player device.

A driver turns simulator readings into Player DATA bodies and Player commands and
requests into simulator calls. The server core never touches the simulator itself; it
calls ``data()``, ``handle_command()`` and ``handle_request()`` from its single I/O and
stepping thread, so drivers need no locking.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

from player_server.protocol.constants import MsgType


@dataclass(frozen=True, slots=True)
class Reply:
    """The answer to a request: ACK with an optional body, or NACK."""

    ack: bool
    body: Any = None


ACK = Reply(True)
NACK = Reply(False)


def ack(body: Any = None) -> Reply:
    return Reply(True, body)


_Spec = TypeVar("_Spec")


def declared(spec: _Spec | None, owner: str, device: str) -> _Spec:
    """The world file's description of a device a driver serves (it must be declared)."""
    if spec is None:
        raise ValueError(f"{owner}: no {device} is declared in the world file")
    return spec


class Unsupported(Exception):
    """The device does not support this command or request (answered with a NACK)."""


PropValue = int | float | str | bool


class Driver:
    """Base class: one Player device (interface + index) and its driver name.

    Subclasses set ``interf`` and override ``data``, ``commands``/``handle_command`` and
    ``requests``/``handle_request``. ``properties`` holds the device's universal
    properties (GET/SET_INT/DBL/STR/BOOLPROP); a subclass may validate in
    ``set_property``.
    """

    interf: ClassVar[int] = 0
    #: the world file's device kind this driver serves on a robot's port
    #: (`registry.robot_drivers` finds it by this); empty for the drivers of other things
    device: ClassVar[str] = ""
    #: CMD subtypes handled by ``handle_command``
    commands: ClassVar[frozenset[int]] = frozenset()
    #: CMD subtypes that only set targets the simulation acts on at its next step: the
    #: device's DATA (and every other device's) stays what it was until then
    deferred_commands: ClassVar[frozenset[int]] = frozenset()
    #: DATA read afresh for every round it goes out in (not cached with the round's other
    #: data, which may be prepared ahead): a device whose data changes between steps
    live: ClassVar[bool] = False
    #: REQ subtypes handled by ``handle_request``
    requests: ClassVar[frozenset[int]] = frozenset()
    #: does the communication watchdog stop this device when its client goes silent?
    watched: ClassVar[bool] = False

    def __init__(self, index: int = 0, driver_name: str = "") -> None:
        self.index = index
        self.driver_name = driver_name or f"sim_{type(self).__name__.lower()}"
        self.properties: dict[str, PropValue] = {}
        #: inclusive (low, high) bounds of numeric properties a client may set; every
        #: number set must be finite, bounded here or not
        self.property_limits: dict[str, tuple[float, float]] = {}

    # -- data ---------------------------------------------------------------------------
    def data(self) -> Sequence[tuple[int, Any]]:
        """The device's current DATA messages as (subtype, body); empty if none."""
        return ()

    def before_step(self) -> None:
        """Called before every simulation step (e.g. to run a controller)."""

    def watchdog_stop(self) -> None:
        """The client driving this device went silent: stop (only if ``watched``)."""

    # -- commands and requests ------------------------------------------------------------
    def handle_command(self, subtype: int, body: Any) -> None:
        raise Unsupported(f"command {subtype}")

    def handle_request(self, subtype: int, body: Any) -> Reply:
        raise Unsupported(f"request {subtype}")

    def supports(self, msg_type: int, subtype: int) -> bool:
        """CAPABILITIES: does this device handle (type, subtype)?"""
        if msg_type == MsgType.CMD:
            return subtype in self.commands
        if msg_type == MsgType.REQ:
            return subtype in self.requests or subtype >= 247
        if msg_type == MsgType.DATA:
            return any(s == subtype for s, _ in self.data())
        return False

    # -- universal properties ----------------------------------------------------------------
    def get_property(self, key: str) -> PropValue:
        return self.properties[key]

    def set_property(self, key: str, value: PropValue) -> None:
        if key not in self.properties:
            raise KeyError(key)
        old = self.properties[key]
        if isinstance(old, bool) is not isinstance(value, bool) or (
            type(old) is not type(value) and not (isinstance(old, float) and isinstance(value, int))
        ):
            raise ValueError(f"property {key!r} holds a {type(old).__name__}")
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"property {key!r} must be finite, got {value}")
        bounds = self.property_limits.get(key)
        if bounds is not None and not isinstance(value, (bool, str)) and not (
                bounds[0] <= value <= bounds[1]):
            raise ValueError(f"property {key!r} must be in [{bounds[0]:g}, {bounds[1]:g}], "
                             f"got {value}")
        self.properties[key] = value

    def close(self) -> None:
        """Release anything held (called when the server stops)."""
