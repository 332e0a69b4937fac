"""What a device model is: one kind of device of the simulated robots, behind one interface.

A model holds the state of its kind of device for every robot that has one, advances it as
the world steps and computes its readings on request (cached by the world until the next
tick). It reads the world through `world.DeviceWorld` (the robots' state, poses, the
clock, the per-tick cache) and never the other way round: the world only builds, advances
and asks its models. Models of sensors that depend on the fidelity compute their readings in
both: ``fast`` (2-D ray casts and projected blobs, numba) and ``render`` (PyBullet rays and
rendered images).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar, Protocol

if TYPE_CHECKING:
    from player_server.sim.devices.world import DeviceWorld


class DeviceModel(Protocol):
    kinds: ClassVar[tuple[str, ...]]
    """The world file's device names this model simulates (e.g. "sonar", "laser")."""
    ticking: ClassVar[bool]
    """Whether it keeps state that `advance` moves on each tick (the world skips the others)."""
    order: ClassVar[int]
    """Where the world builds and advances it among the models (lower first; a model that
    reads another's state this tick comes after it: power after position2d)."""

    def __init__(self, world: DeviceWorld) -> None: ...

    def build(self) -> None:
        """The world was built (or rebuilt at tick 0): fresh state for every robot with the
        device."""
        ...

    def advance(self, dt: float) -> None:
        """One tick of `dt` seconds has passed (after physics and odometry)."""
        ...


class StatelessModel:
    """A model whose readings follow from the world alone: nothing to build, nothing that
    moves on with the ticks (`ticking` False). A model with state overrides `build`."""

    kinds: ClassVar[tuple[str, ...]] = ()
    ticking: ClassVar[bool] = False
    order: ClassVar[int] = 100

    def __init__(self, world: DeviceWorld) -> None:
        self.world = world

    def build(self) -> None:
        pass

    def advance(self, dt: float) -> None:
        pass
