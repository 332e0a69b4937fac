"""CBBA (Choi, Brunet & How 2009) on the robots: consensus on single-robot tasks."""

from __future__ import annotations

from murdoch.allocators.consensus import consensus_allocator

CBBA = consensus_allocator("cbba", "consensus-based bundles: each robot plans a path of tasks")
