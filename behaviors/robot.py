"""Assembling a robot: a connected Player client in, a ready `RobotAgent` out.

This is the small Python API the robot process (and an experiment runner that prefers to
run robots in-process) uses:

    client = PlayerClient("127.0.0.1", port).connect()
    agent = build_agent(client, name="r1", world=load_world(world_path("longterm")))
    agent.start_task("goto-goal", {"x": 1.0, "y": 2.0}, task_id="t1")
    agent.run(stop_event)

The world description, when given, tells the robot where the chargers are, its camera's
field of view and, for the overhead camera, which part of the floor it sees.
"""

from __future__ import annotations

import math

from behaviors.agent import RobotAgent
from behaviors.battery import BatteryPolicy
from behaviors.events import EventLog
from behaviors.profile import Charger, OverheadView, RobotProfile, subjects_for
from behaviors.sensing import FrameOffset, PlayerRobotIO
from player_server.client import PlayerClient
from worlds import BoxSpec, ObjectSpec, WorldSpec


def profile_from(
    name: str,
    interfaces: frozenset[str],
    world: WorldSpec | None = None,
    seed: int = 0,
    bid_terms: tuple[str, ...] = (),
) -> RobotProfile:
    """A robot's profile from the interfaces its server port lists and the world file."""
    subjects = subjects_for(interfaces)
    chargers: tuple[Charger, ...] = ()
    overhead = None
    landmarks: tuple[tuple[int, float, float], ...] = ()
    fov = math.radians(60.0)
    max_speed, max_turn = 0.5, 1.5
    if world is not None:
        coloured: tuple[BoxSpec | ObjectSpec, ...] = (*world.objects, *world.boxes)
        landmarks = tuple((b.colour, b.pose.x, b.pose.y) for b in coloured)
        chargers = tuple(Charger(c.name, c.x, c.y, c.radius_m) for c in world.chargers
                         if c.rate_w > 0)  # a drain (take only) is no charger
        robot = next((r for r in world.robots if r.name == name), None)
        if robot is not None:
            if robot.devices.camera is not None:
                fov = robot.devices.camera.fov_h_rad
            if robot.devices.position2d is not None:
                max_speed = robot.devices.position2d.max_speed_mps
                max_turn = robot.devices.position2d.max_yaw_rate_radps
        cam = world.overhead_camera
        if cam is not None and "mobile" not in subjects:
            overhead = OverheadView(cam.x, cam.y, cam.view_size_x_m, cam.view_size_y_m)
    return RobotProfile(name, subjects, max_speed_mps=max_speed, max_turn_radps=max_turn,
                        camera_fov_rad=fov, chargers=chargers, overhead=overhead, seed=seed,
                        landmarks=landmarks, bid_terms=bid_terms)


def build_agent(
    client: PlayerClient,
    name: str,
    *,
    world: WorldSpec | None = None,
    events: EventLog | None = None,
    battery: BatteryPolicy | None = None,
    seed: int = 0,
    subscribe_images: bool = False,
    odometry_offset: FrameOffset | None = None,
    bid_terms: tuple[str, ...] = (),
) -> RobotAgent:
    """Discover and subscribe the devices behind `client`'s port and build the agent."""
    fov = math.radians(60.0)
    if world is not None:
        robot = next((r for r in world.robots if r.name == name), None)
        if robot is not None:
            if robot.devices.camera is not None:
                fov = robot.devices.camera.fov_h_rad
            if odometry_offset is None:
                # Odometry starts at (0, 0, 0) where the robot starts; the world file says
                # where that is, so goals and chargers can be given in world coordinates.
                odometry_offset = FrameOffset(robot.pose.x, robot.pose.y, robot.pose.yaw)
    io = PlayerRobotIO(client, camera_fov_rad=fov, subscribe_images=subscribe_images,
                       odometry_offset=odometry_offset)
    interfaces = io.open()
    profile = profile_from(name, interfaces, world, seed, bid_terms)
    return RobotAgent(io, profile, events=events, battery=battery)
