"""CBGA (Hunt, Meng, Hinde & Huang 2014) on the robots: consensus with equipment.

A robot's devices (its resource subjects: camera, laser, bumper, gripper, overhead-camera,
mobile ...) are its equipment, and a task's required subjects the equipment it needs."""

from __future__ import annotations

from murdoch.allocators.consensus import consensus_allocator

CBGA = consensus_allocator("cbga", "consensus-based grouping: bundles with equipment and groups")
