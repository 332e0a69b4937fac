"""Top speeds of the behaviours driven by a `speed_mps` setting (what the contract checks).

A behaviour lists one of these as its base: the setting is then the one source of the limit
its proposals are held to.
"""

from __future__ import annotations


class ForwardSpeedLimit:
    """Drives forward at up to `speed_mps`: a negative setting is a negative (invalid) limit."""

    __slots__ = ()
    speed_mps: float

    @property
    def max_speed_mps(self) -> float:
        return self.speed_mps


class ReversibleSpeedLimit:
    """Drives at `speed_mps`, forward or (negative) backward: the limit is its magnitude."""

    __slots__ = ()
    speed_mps: float

    @property
    def max_speed_mps(self) -> float:
        return abs(self.speed_mps)
