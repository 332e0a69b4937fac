"""What a device model is given: the world it reads, as a small typed interface.

A model is built with a `DeviceWorld` (the Simulation implements it) and reaches the world
only through it: the robots' state (`state.RobotState`: body, pose, drive), the device's
world-file parameters (``state.spec.devices.<kind>``), the clock (``tick``) and the per-tick
cache, the bodies' poses and neighbours (`Poses`), the PyBullet client for models that render
or cast rays themselves, how bodies look (colours and fiducial ids, which the
simulation interface may change), and the few world changes a model may ask for (hiding an object,
say). Nothing here imports the simulation, so a model never depends on the world that holds
it; a test can hand a model any object with these members.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from player_server.sim.bodies import BodyIds
    from player_server.sim.devices.state import RobotState
    from player_server.sim.fastsense import Frame
    from player_server.sim.looks import Looks
    from player_server.sim.readings import SceneSnapshot
    from player_server.sim.world_arrays import WorldArrays
    from worlds import ObjectSpec, WorldSpec

Sensed = dict[str, dict[Any, Any]]
"""One tick's sensing pass: {"ranges": {(robot index, kind): array}, "blobs": {index: blobs}}"""


class Poses(Protocol):
    """This tick's poses and neighbourhoods, read once per tick and cached."""

    def frame(self) -> Frame:
        """Every robot's axle position, heading and body centre (by robot index)."""
        ...

    def dynamic_poses(self) -> NDArray[np.float64]:
        """(n_boxes + n_objects, 3) poses of the movable bodies, boxes first."""
        ...

    def dyn_pose(self, name: str) -> tuple[float, float, float]: ...

    def robots_near(self, x: float, y: float, reach: float) -> list[int]: ...

    def objects_near(self, x: float, y: float, reach: float) -> list[int]: ...

    def target_poses(self, frame: Frame) -> tuple[np.ndarray, np.ndarray]: ...


class DeviceWorld(Protocol):
    """The world as a device model sees it."""

    spec: WorldSpec
    fidelity: str
    tick: int
    robots: list[RobotState]
    """Every robot's state, by index (world-file order)."""
    physics_client: int
    ids: BodyIds
    arrays: WorldArrays
    """The world's fixed geometry as arrays (footprints, targets, room)."""
    robot_offset: NDArray[np.float64]
    noise_seed: int
    """The seed of noise drawn per tick (`np.random.default_rng([noise_seed, tick])`)."""
    hidden: set[str]
    """Objects taken out of the world (stored in a gripper)."""
    held: set[str]
    """Objects held between a gripper's paddles."""
    target_hidden: np.ndarray | None
    looks: Looks
    """Each body's colour and fiducial id in force (``looks.version`` counts changes);
    ``arrays`` is rebuilt with the colours when one changes."""

    @property
    def tick_arrays(self) -> Poses: ...

    def device(self, robot: str, kind: str) -> RobotState:
        """The state of `robot`, which must have a device `kind` (ValueError, KeyError)."""
        ...

    def cached(self, key: object, compute: Callable[[], object]) -> object:
        """`compute()` once per tick under `key` (and after every `invalidate`)."""
        ...

    def invalidate(self) -> None:
        """The world changed within the tick: forget this tick's cached readings."""
        ...

    def sensed_now(self) -> Sensed | None:
        """This tick's sensing pass if it has run, else None."""
        ...

    def sense(self) -> Sensed:
        """This tick's sensing pass, run now for the active sensors if it has not yet."""
        ...

    def ptz_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every robot's pan, tilt and zoom (zeros without a head), by robot index."""
        ...

    def snapshot(self) -> SceneSnapshot: ...

    def object_spec(self, name: str) -> ObjectSpec: ...

    def hide_object(self, name: str) -> None: ...

    def unhide_object(self, name: str) -> None: ...

    def update_visibility(self) -> None:
        """`held` or `hidden` changed: the ray caster and blobfinders see it."""
        ...

