"""Pan-tilt-zoom heads: targets set by command, reached at the head's maximum speeds."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from player_server.sim.devices.state import PtzHead
from player_server.sim.drive import ramp
from player_server.sim.readings import PtzState, fast_constructor

_make_ptz_state = fast_constructor(PtzState)

if TYPE_CHECKING:
    from player_server.sim.devices.state import RobotState
    from player_server.sim.devices.world import DeviceWorld


class PtzModel:
    kinds: ClassVar[tuple[str, ...]] = ("ptz",)
    order: ClassVar[int] = 40
    ticking: ClassVar[bool] = True

    def __init__(self, world: DeviceWorld) -> None:
        self.world = world
        self.any = False

    def build(self) -> None:
        for st in self.world.robots:
            d = st.spec.devices
            if d.ptz is not None and d.camera is not None:
                st.ptz = PtzHead(zoom=d.camera.fov_h_rad, zoom_target=d.camera.fov_h_rad)
        self.any = any(st.ptz is not None for st in self.world.robots)
        self._zeros = np.zeros(len(self.world.robots))

    def advance(self, dt: float) -> None:
        for st in self.world.robots:
            if st.ptz is not None:
                self._advance_ptz(st, dt)

    def _advance_ptz(self, st: RobotState, dt: float) -> None:
        spec = st.spec.devices.ptz
        p = st.ptz
        assert spec is not None and p is not None
        pan = ramp(p.pan, p.pan_target, spec.pan_speed_radps * dt)
        tilt = ramp(p.tilt, p.tilt_target, spec.tilt_speed_radps * dt)
        p.pan_speed, p.tilt_speed = (pan - p.pan) / dt, (tilt - p.tilt) / dt
        p.pan, p.tilt = pan, tilt
        p.zoom = ramp(p.zoom, p.zoom_target, spec.zoom_speed_radps * dt)

    def ptz(self, robot: str) -> PtzState:
        st = self.world.device(robot, "ptz")
        p = st.ptz
        assert p is not None
        return _make_ptz_state(p.pan, p.tilt, p.zoom, p.pan_speed, p.tilt_speed)

    def ptz_command(self, robot: str, pan: float, tilt: float, zoom: float) -> None:
        st = self.world.device(robot, "ptz")
        spec = st.spec.devices.ptz
        p = st.ptz
        assert spec is not None and p is not None
        for v in (pan, tilt, zoom):
            if not math.isfinite(v):
                raise ValueError("ptz targets must be finite")
        p.pan_target = min(spec.pan_max_rad, max(spec.pan_min_rad, float(pan)))
        p.tilt_target = min(spec.tilt_max_rad, max(spec.tilt_min_rad, float(tilt)))
        p.zoom_target = min(spec.zoom_max_rad, max(spec.zoom_min_rad, float(zoom)))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every robot's pan, tilt and zoom (zeros without a head), by robot index."""
        robots = self.world.robots
        n = len(robots)
        if not self.any:
            z = self._zeros
            return z, z, z
        pan, tilt, zoom = np.zeros(n), np.zeros(n), np.zeros(n)
        for st in robots:
            if st.ptz is not None:
                pan[st.index], tilt[st.index], zoom[st.index] = st.ptz.pan, st.ptz.tilt, \
                    st.ptz.zoom
        return pan, tilt, zoom
