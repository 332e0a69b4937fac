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
from typing import Any, TypeVar

from behaviors.snapshot import (
    BlobView,
    Bumpers,
    Deferred,
    Gripper,
    Mark,
    Odometry,
    Power,
    RangeScan,
    Snapshot,
    make_blob,
    make_blob_view,
    make_bumpers,
    make_gripper,
    make_lazy_snapshot,
    make_odometry,
    make_pose,
    make_power,
    make_scan,
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
    ScanBody,
    SonarProxy,
)
from player_server.protocol import constants as c
from player_server.protocol.constants import MsgType, interface_name

logger = logging.getLogger(__name__)
T = TypeVar("T")

# Devices opened like every other but whose DATA no behaviour reads: raw camera images are
# large and nothing looks at pixels (the blobfinder carries what the behaviours need), and
# nothing reads fiducial scans. Their DATA is declined with an IGNORE replace rule (the
# server then makes none); images are kept when asked for.
IMAGE_INTERFACES = frozenset({"camera"})
UNREAD_INTERFACES = IMAGE_INTERFACES | {"fiducial"}


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


def _odometry_reading(v: tuple[float, float, float, float, float, float, int], time_s: float,
                      trig: tuple[FrameOffset, float, float] | None) -> Odometry:
    """An odometry reading from position2d state values, moved into the world frame."""
    x, y, yaw = v[0], v[1], v[2]
    if trig is not None:
        offset, c, s = trig
        x, y, yaw = (offset.x_m + c * x - s * y, offset.y_m + s * x + c * y,
                     wrap_angle(offset.yaw_rad + yaw))
    return make_odometry(make_pose(x, y, yaw), v[3], v[5], bool(v[6]), time_s)


def _blob_view(v: tuple[int, int, tuple[tuple[Any, ...], ...]], fov_rad: float,
               time_s: float) -> BlobView:
    """A camera reading from blobfinder values: (width, height, blobs), each blob (id, color,
    area, x, y, left, right, top, bottom, range)."""
    inf = math.inf
    blobs = tuple([
        make_blob(b[1] & 0xFFFFFF, b[2], float(b[3]), float(b[4]), b[5], b[6], b[7], b[8],
                  b[9] if b[9] > 0 else inf)
        for b in v[2]
    ])
    return make_blob_view(v[0], v[1], blobs, fov_rad, time_s)


class PlayerRobotIO:
    """One robot's devices through a connected `PlayerClient`."""

    def __init__(
        self,
        client: PlayerClient,
        *,
        camera_fov_rad: float = math.radians(60.0),
        subscribe_images: bool = False,
        odometry_offset: FrameOffset | None = None,
        request_timeout_s: float | None = None,
    ) -> None:
        self.client = client
        self.camera_fov_rad = camera_fov_rad
        self.subscribe_images = subscribe_images
        self.odometry_offset = odometry_offset
        self._timeout_s = request_timeout_s
        self.interfaces: frozenset[str] = frozenset()
        self.proxies: dict[str, Proxy] = {}
        self._position: Position2dProxy | None = None
        self._sonar_geometry: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
        self._laser_pose = (0.0, 0.0, 0.0)
        self._laser_bearings: dict[tuple[float, float, int], tuple[tuple[float, ...],
                                                                   tuple[float, ...]]] = {}
        self._bumper_front: tuple[bool, ...] = ()
        self._last_command: tuple[float, float] | None = None
        # per-reading caches: (proxy's data_count when built, the reading)
        self._odo_hit: tuple[int, Odometry | Deferred | None] = (-1, None)
        self._sonar_hit: tuple[int, RangeScan | Deferred | None] = (-1, None)
        self._laser_hit: tuple[int, RangeScan | Deferred | None] = (-1, None)
        self._blob_hit: tuple[int, BlobView | Deferred | None] = (-1, None)
        self._bumper_hit: tuple[int, Bumpers | None] = (-1, None)
        self._power_hit: tuple[int, Power | None] = (-1, None)
        self._sonar_proxy: SonarProxy | None = None
        self._laser_proxy: LaserProxy | RangerProxy | None = None
        self._blob_proxy: BlobfinderProxy | None = None
        self._bumper_proxy: BumperProxy | None = None
        self._power_proxy: PowerProxy | None = None
        self._gripper_proxy: GripperProxy | None = None
        self._resolved: dict[str, Proxy] = {}
        self._sonar_spread: tuple[float, ...] = ()
        self._offset_trig: tuple[FrameOffset, float, float] | None = None

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
            proxy = self.client.subscribe(PROXIES[name], addr.index, self._timeout_s)
            self.proxies[name] = proxy
            if name in UNREAD_INTERFACES and not (self.subscribe_images
                                                  and name in IMAGE_INTERFACES):
                self.client.set_replace_rule(c.PLAYER_PLAYER_MSG_REPLACE_RULE_IGNORE,
                                             addr.interf, addr.index, int(MsgType.DATA))
        self.interfaces = frozenset(found - {"simulation", "player", "opaque"})
        self._read_geometry()
        self._resolve()
        logger.info("devices: %s; subscribed: %s", sorted(found), sorted(self.proxies))
        return self.interfaces

    def _resolve(self) -> None:
        """Pick each reading's proxy once, so a tick does no lookups or type checks."""
        proxies = self.proxies
        position = proxies.get("position2d")
        self._position = position if isinstance(position, Position2dProxy) else None
        sonar = proxies.get("sonar")
        laser = proxies.get("laser") or proxies.get("ranger")
        blobs = proxies.get("blobfinder")
        bumper = proxies.get("bumper")
        power = proxies.get("power")
        gripper = proxies.get("gripper")
        self._sonar_proxy = sonar if isinstance(sonar, SonarProxy) else None
        self._laser_proxy = laser if isinstance(laser, LaserProxy | RangerProxy) else None
        self._blob_proxy = blobs if isinstance(blobs, BlobfinderProxy) else None
        self._bumper_proxy = bumper if isinstance(bumper, BumperProxy) else None
        self._power_proxy = power if isinstance(power, PowerProxy) else None
        self._gripper_proxy = gripper if isinstance(gripper, GripperProxy) else None
        self._resolved = dict(proxies)

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
        """The proxies' latest values as a snapshot (no I/O).

        Each reading is rebuilt only when its device sent new data since the last snapshot
        (the proxy's data count moved); otherwise the previous, frozen reading is reused.
        Odometry, sonar, laser and camera readings are `Deferred`: built from the values
        captured now by whichever thread reads them first, and not at all when no one
        does (many tasks never look at the laser or odometry; an idle robot looks at none).
        """
        if self.proxies != self._resolved:
            self._resolve()
        return make_lazy_snapshot(
            self.client.data_time_s or 0.0,
            self._odometry(),
            self._sonar(),
            self._laser(),
            self._blobs(),
            self._bumpers(),
            self._power(),
            self._gripper(),
            mark,
        )

    def _odometry(self) -> Odometry | Deferred | None:
        proxy = self._position
        if proxy is None:
            return None
        count = proxy.data_count
        hit = self._odo_hit
        if hit[0] == count:
            return hit[1]
        v = proxy.state_values
        if v is None:
            return None
        offset = self.odometry_offset
        trig = None
        if offset is not None:
            trig = self._offset_trig
            if trig is None or trig[0] is not offset:
                trig = self._offset_trig = (offset, math.cos(offset.yaw_rad),
                                            math.sin(offset.yaw_rad))
        value = Deferred(_odometry_reading, v, proxy.data_time_s or 0.0, trig)
        self._odo_hit = (count, value)
        return value

    def _sonar(self) -> RangeScan | Deferred | None:
        proxy = self._sonar_proxy
        if proxy is None:
            return None
        count = proxy.data_count
        hit = self._sonar_hit
        if hit[0] == count:
            return hit[1]
        if not count:
            return None
        value = Deferred(self._sonar_reading, proxy.ranges, proxy.data_time_s or 0.0)
        self._sonar_hit = (count, value)
        return value

    def _sonar_reading(self, ranges: tuple[float, ...], time_s: float) -> RangeScan:
        bearings, offsets = self._sonar_geometry
        if len(bearings) != len(ranges):
            # No geometry: spread the transducers evenly around the robot.
            n = len(ranges)
            spread = self._sonar_spread
            if len(spread) != n:
                spread = self._sonar_spread = tuple(
                    wrap_angle(2 * math.pi * i / n) for i in range(n))
            bearings = spread
            offsets = ()
        return make_scan(ranges, bearings, max(ranges, default=0.0), time_s, offsets, 0)

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

    def _laser(self) -> RangeScan | Deferred | None:
        proxy = self._laser_proxy
        if proxy is None:
            return None
        count = proxy.data_count
        hit = self._laser_hit
        if hit[0] == count:
            return hit[1]
        if not count:
            return None
        value: Deferred
        if isinstance(proxy, LaserProxy):
            body = proxy.scan_body  # its ranges are decoded only if the reading is built
            if body is None:
                return None
            value = Deferred(self._laser_body_reading, body, proxy.data_time_s or 0.0)
        else:
            cfg = proxy.config
            if cfg is None:
                return None
            value = Deferred(self._laser_reading, proxy.ranges, cfg.min_angle, cfg.angular_res,
                             cfg.max_range, proxy.data_time_s or 0.0, 0)
        self._laser_hit = (count, value)
        return value

    def _laser_body_reading(self, body: ScanBody, time_s: float) -> RangeScan:
        # (min_angle, max_angle, resolution, max_range, ranges, intensity, id)
        v = body.values()
        return self._laser_reading(v[4], v[0], v[2], v[3], time_s, v[6])

    def _laser_reading(self, ranges: tuple[float, ...], min_angle: float, resolution: float,
                       max_range: float, time_s: float, scan_id: int) -> RangeScan:
        bearings, offsets = self._bearings(min_angle, resolution, len(ranges))
        return make_scan(ranges, bearings, max_range, time_s, offsets, scan_id)

    def _blobs(self) -> BlobView | Deferred | None:
        proxy = self._blob_proxy
        if proxy is None:
            return None
        count = proxy.data_count
        hit = self._blob_hit
        if hit[0] == count:
            return hit[1]
        v = proxy.blob_values
        if v is None:
            return None
        value = Deferred(_blob_view, v, self.camera_fov_rad, proxy.data_time_s or 0.0)
        self._blob_hit = (count, value)
        return value

    def _bumpers(self) -> Bumpers | None:
        proxy = self._bumper_proxy
        if proxy is None:
            return None
        count = proxy.data_count
        hit = self._bumper_hit
        if hit[0] == count:
            return hit[1]
        if not count:
            return None
        value = make_bumpers(proxy.bumpers, proxy.data_time_s or 0.0, self._bumper_front)
        self._bumper_hit = (count, value)
        return value

    def _power(self) -> Power | None:
        proxy = self._power_proxy
        if proxy is None:
            return None
        count = proxy.data_count
        hit = self._power_hit
        if hit[0] == count:
            return hit[1]
        v = proxy.state_values  # (valid, volts, percent, joules, watts, charging)
        if v is None:
            return None
        value = make_power(v[2], v[1], v[5], proxy.data_time_s or 0.0)
        self._power_hit = (count, value)
        return value

    def _gripper(self) -> Gripper | None:
        proxy = self._gripper_proxy
        if proxy is None or proxy.state_data is None:
            return None
        st = proxy.state_data
        return make_gripper(st.state, st.beams, st.stored, proxy.data_time_s or 0.0)

    def command(self, vx_mps: float, vyaw_radps: float) -> None:
        """Send a velocity command (every tick: in lockstep a command marks the tick done).

        The command leaves with the next message the client sends (the next round's
        REQ DATA, in order before it), so a tick costs one send; `flush()` sends it now.
        """
        if self._position is not None:
            self._position.set_velocity(vx_mps, vyaw_radps, defer=True)

    def flush(self) -> None:
        """Send a command still held back (see `command`)."""
        if self.client.connected:
            self.client.flush()

    def close(self) -> None:
        try:
            if self._position is not None and self.client.connected:
                self._position.stop()
        finally:
            self.client.close()
