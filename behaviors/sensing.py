"""The robot's devices over the Player client: discovery, subscription, snapshots, commands.

`PlayerRobotIO` lists the devices behind one server port, subscribes to them, reads their
geometry once, and then turns each data round into a frozen `Snapshot`. Readings whose
device sent nothing new are reused, not rebuilt, so a tick allocates little.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

from behaviors.snapshot import (
    Blob,
    BlobView,
    Bumpers,
    Gripper,
    Mark,
    Odometry,
    Pose2D,
    Power,
    RangeScan,
    Snapshot,
    wrap_angle,
)
from player_server.client import (
    PROXIES,
    BlobfinderProxy,
    BumperProxy,
    GripperProxy,
    LaserProxy,
    PlayerClient,
    PlayerNack,
    PlayerTimeout,
    Position2dProxy,
    PowerProxy,
    Proxy,
    RangerProxy,
    SonarProxy,
)
from player_server.protocol.constants import interface_name

logger = logging.getLogger(__name__)
T = TypeVar("T")

# Raw camera images are large and nothing in the behaviours looks at pixels (the blobfinder
# carries what they need), so they are only subscribed on request.
IMAGE_INTERFACES = frozenset({"camera"})


@dataclass(frozen=True, slots=True)
class FrameOffset:
    """Maps odometry (which starts at 0, 0, 0) into the world frame of the robot's start."""

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0

    def apply(self, x: float, y: float, yaw: float) -> tuple[float, float, float]:
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        return (self.x_m + c * x - s * y, self.y_m + s * x + c * y,
                wrap_angle(self.yaw_rad + yaw))


class PlayerRobotIO:
    """One robot's devices through a connected `PlayerClient`."""

    def __init__(
        self,
        client: PlayerClient,
        *,
        camera_fov_rad: float = math.radians(60.0),
        subscribe_images: bool = False,
        odometry_offset: FrameOffset | None = None,
        request_timeout_s: float = 5.0,
    ) -> None:
        self.client = client
        self.camera_fov_rad = camera_fov_rad
        self.subscribe_images = subscribe_images
        self.odometry_offset = odometry_offset
        self._timeout_s = request_timeout_s
        self.interfaces: frozenset[str] = frozenset()
        self.proxies: dict[str, Proxy] = {}
        self._position: Position2dProxy | None = None
        self._cache: dict[str, tuple[int, object]] = {}
        self._sonar_geometry: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
        self._laser_pose = (0.0, 0.0, 0.0)
        self._laser_bearings: dict[tuple[float, float, int], tuple[tuple[float, ...],
                                                                   tuple[float, ...]]] = {}
        self._bumper_front: tuple[bool, ...] = ()
        self._last_command: tuple[float, float] | None = None

    # -- discovery ---------------------------------------------------------------------------

    def open(self) -> frozenset[str]:
        """List the devices behind this port, subscribe to them, read their geometry.

        Returns the names of the interfaces found (the robot's device set).
        """
        found: set[str] = set()
        for addr in self.client.devlist():
            name = interface_name(addr.interf)
            found.add(name)
            if addr.index != 0 or name not in PROXIES or name in self.proxies:
                continue
            if name in IMAGE_INTERFACES and not self.subscribe_images:
                continue
            proxy = self.client.subscribe(PROXIES[name], addr.index, self._timeout_s)
            self.proxies[name] = proxy
        self.interfaces = frozenset(found - {"simulation", "player"})
        self._read_geometry()
        position = self.proxies.get("position2d")
        self._position = position if isinstance(position, Position2dProxy) else None
        logger.info("devices: %s; subscribed: %s", sorted(found), sorted(self.proxies))
        return self.interfaces

    def _geometry(self, fetch: Callable[[], T], what: str) -> T | None:
        try:
            return fetch()
        except (PlayerNack, PlayerTimeout) as exc:
            logger.warning("no %s geometry (%s); using defaults", what, exc)
            return None

    def _read_geometry(self) -> None:
        sonar = self.proxies.get("sonar")
        if isinstance(sonar, SonarProxy):
            poses = self._geometry(lambda: sonar.get_geometry(self._timeout_s), "sonar")
            if poses:
                bearings = tuple(wrap_angle(p.pyaw) for p in poses)
                offsets = tuple(p.px * math.cos(p.pyaw) + p.py * math.sin(p.pyaw) for p in poses)
                self._sonar_geometry = (bearings, offsets)
        laser = self.proxies.get("laser")
        if isinstance(laser, LaserProxy):
            geom = self._geometry(lambda: laser.get_geometry(self._timeout_s), "laser")
            if geom is not None:
                pose = geom.pose
                self._laser_pose = (pose.px, pose.py, pose.pyaw)
        ranger = self.proxies.get("ranger")
        if isinstance(ranger, RangerProxy) and "laser" not in self.proxies:
            self._geometry(lambda: ranger.get_config(self._timeout_s), "ranger")
            rgeom = self._geometry(lambda: ranger.get_geometry(self._timeout_s), "ranger")
            if rgeom is not None:
                pose = rgeom.pose
                self._laser_pose = (pose.px, pose.py, pose.pyaw)
        bumper = self.proxies.get("bumper")
        if isinstance(bumper, BumperProxy):
            bgeom = self._geometry(lambda: bumper.get_geometry(self._timeout_s), "bumper")
            if bgeom is not None:
                self._bumper_front = tuple(
                    d.pose.px > 0.0 for d in bgeom.bumper_def
                )

    # -- per tick ----------------------------------------------------------------------------

    def read(self, mark: Mark | None) -> Snapshot:
        """Wait for the next data round and return it as a snapshot."""
        self.client.read()
        return self.snapshot(mark)

    def snapshot(self, mark: Mark | None) -> Snapshot:
        """The proxies' latest values as a snapshot (no I/O)."""
        proxies = self.proxies
        t = self.client.data_time_s or 0.0
        return Snapshot(
            time_s=t,
            odometry=self._odometry(proxies.get("position2d")),
            sonar=self._sonar(proxies.get("sonar")),
            laser=self._laser(proxies.get("laser") or proxies.get("ranger")),
            camera=self._blobs(proxies.get("blobfinder")),
            bumpers=self._bumpers(proxies.get("bumper")),
            power=self._power(proxies.get("power")),
            gripper=self._gripper(proxies.get("gripper")),
            mark=mark,
        )

    def _cached(self, key: str, proxy: Proxy) -> object | None:
        hit = self._cache.get(key)
        if hit is not None and hit[0] == proxy.data_count:
            return hit[1]
        return None

    def _store(self, key: str, proxy: Proxy, value: object) -> None:
        self._cache[key] = (proxy.data_count, value)

    def _odometry(self, proxy: Proxy | None) -> Odometry | None:
        if not isinstance(proxy, Position2dProxy) or proxy.state is None:
            return None
        hit = self._cached("odometry", proxy)
        if hit is not None:
            return hit  # type: ignore[return-value]
        st = proxy.state
        x, y, yaw = st.pos.px, st.pos.py, st.pos.pa
        if self.odometry_offset is not None:
            x, y, yaw = self.odometry_offset.apply(x, y, yaw)
        value = Odometry(Pose2D(x, y, yaw), st.vel.px, st.vel.pa, bool(st.stall),
                         proxy.data_time_s or 0.0)
        self._store("odometry", proxy, value)
        return value

    def _sonar(self, proxy: Proxy | None) -> RangeScan | None:
        if not isinstance(proxy, SonarProxy) or not proxy.fresh:
            return None
        hit = self._cached("sonar", proxy)
        if hit is not None:
            return hit  # type: ignore[return-value]
        ranges = proxy.ranges
        bearings, offsets = self._sonar_geometry
        if len(bearings) != len(ranges):
            # No geometry: spread the transducers evenly around the robot.
            n = len(ranges)
            bearings = tuple(wrap_angle(2 * math.pi * i / n) for i in range(n)) if n else ()
            offsets = ()
        value = RangeScan(ranges, bearings, max(ranges, default=0.0), proxy.data_time_s or 0.0,
                          offsets)
        self._store("sonar", proxy, value)
        return value

    def _bearings(self, min_angle: float, resolution: float, n: int) -> tuple[
        tuple[float, ...], tuple[float, ...]
    ]:
        key = (min_angle, resolution, n)
        hit = self._laser_bearings.get(key)
        if hit is None:
            px, py, pyaw = self._laser_pose
            bearings = tuple(wrap_angle(pyaw + min_angle + i * resolution) for i in range(n))
            offsets = tuple(px * math.cos(b) + py * math.sin(b) for b in bearings)
            hit = (bearings, offsets)
            self._laser_bearings[key] = hit
        return hit

    def _laser(self, proxy: Proxy | None) -> RangeScan | None:
        if proxy is None or not proxy.fresh:
            return None
        hit = self._cached("laser", proxy)
        if hit is not None:
            return hit  # type: ignore[return-value]
        if isinstance(proxy, LaserProxy) and proxy.scan is not None:
            scan = proxy.scan
            bearings, offsets = self._bearings(scan.min_angle, scan.resolution, len(scan.ranges))
            value = RangeScan(scan.ranges, bearings, scan.max_range, proxy.data_time_s or 0.0,
                              offsets, scan.id)
        elif isinstance(proxy, RangerProxy) and proxy.config is not None:
            cfg = proxy.config
            bearings, offsets = self._bearings(cfg.min_angle, cfg.angular_res, len(proxy.ranges))
            value = RangeScan(proxy.ranges, bearings, cfg.max_range, proxy.data_time_s or 0.0,
                              offsets)
        else:
            return None
        self._store("laser", proxy, value)
        return value

    def _blobs(self, proxy: Proxy | None) -> BlobView | None:
        if not isinstance(proxy, BlobfinderProxy) or proxy.state is None:
            return None
        hit = self._cached("blobs", proxy)
        if hit is not None:
            return hit  # type: ignore[return-value]
        st = proxy.state
        blobs = tuple(
            Blob(b.color & 0xFFFFFF, b.area, float(b.x), float(b.y), b.left, b.right, b.top,
                 b.bottom, b.range if b.range > 0 else math.inf)
            for b in st.blobs
        )
        value = BlobView(st.width, st.height, blobs, self.camera_fov_rad,
                         proxy.data_time_s or 0.0)
        self._store("blobs", proxy, value)
        return value

    def _bumpers(self, proxy: Proxy | None) -> Bumpers | None:
        if not isinstance(proxy, BumperProxy) or not proxy.fresh:
            return None
        hit = self._cached("bumpers", proxy)
        if hit is not None:
            return hit  # type: ignore[return-value]
        value = Bumpers(proxy.bumpers, proxy.data_time_s or 0.0, self._bumper_front)
        self._store("bumpers", proxy, value)
        return value

    def _power(self, proxy: Proxy | None) -> Power | None:
        if not isinstance(proxy, PowerProxy) or proxy.state is None:
            return None
        hit = self._cached("power", proxy)
        if hit is not None:
            return hit  # type: ignore[return-value]
        st = proxy.state
        value = Power(st.percent, st.volts, st.charging, proxy.data_time_s or 0.0)
        self._store("power", proxy, value)
        return value

    def _gripper(self, proxy: Proxy | None) -> Gripper | None:
        if not isinstance(proxy, GripperProxy) or proxy.state_data is None:
            return None
        st = proxy.state_data
        return Gripper(st.state, st.beams, st.stored, proxy.data_time_s or 0.0)

    def command(self, vx_mps: float, vyaw_radps: float) -> None:
        """Send a velocity command (every tick: in lockstep a command marks the tick done)."""
        if self._position is not None:
            self._position.set_velocity(vx_mps, vyaw_radps)

    def close(self) -> None:
        try:
            if self._position is not None and self.client.connected:
                self._position.stop()
        finally:
            self.client.close()
