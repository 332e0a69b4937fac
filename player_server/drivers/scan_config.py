"""What a scanning range finder's configuration requests may ask, as a SICK LMS answers them.

Pure: `scan_config(spec, request, interval_s)` returns the `ScanConfig` to put in force or
raises ValueError naming what cannot be done. The simulated scan (the world's `samples`
over its field of view) is the finest there is: a configuration picks a window of its
readings, every n-th of them, a shorter range, a coarser range resolution (ranges are
rounded to it), intensities on or off, and a new scan every k simulation steps.

A window that is not on the simulated readings, or finer than them, at one of a SICK LMS's
angular resolutions (25, 50 or 100 hundredths of a degree) is a fan of its own
(`ScanConfig.fan`): the simulator casts those rays instead (`SimPort.set_scan_fan`); its
first reading is at min_angle, then one every resolution up to max_angle (the last at most
one step short of it).

Units as clients send them: an angular resolution of exactly 25, 50 or 100 is in hundredths
of a degree (a SICK LMS's 0.25, 0.5 and 1 degree; 0.25 degree only over at most 100 degrees),
any other value radians; a range resolution of exactly 1, 10 or 100 is in millimetres, any
other value metres. GET_CONFIG answers in the units the client used. Fields a client leaves
unset (zero, negative, NaN) keep their current value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

SICK_RESOLUTIONS = (25.0, 50.0, 100.0)  # hundredths of a degree
SICK_RANGE_RES_MM = (1.0, 10.0, 100.0)
_TOLERANCE = 1e-3  # of a reading's spacing
_FOV_SLACK = 1e-6  # rad: a fan's ends may be this far outside the field of view

Fan = tuple[float, float, int]
"""A fan of rays cast for a configuration: first angle (rad), spacing (rad), count."""


@dataclass(frozen=True)
class ScanRequest:
    """A SET_CONFIG's fields (laser or ranger), as sent."""

    min_angle: float
    max_angle: float
    resolution: float
    max_range: float
    range_res: float
    intensity: bool
    frequency_hz: float


@dataclass(frozen=True)
class ScanConfig:
    """A window of the simulated scan: readings first..last every step-th (indices into it)."""

    first: int
    last: int
    step: int
    max_range_m: float
    range_res_m: float
    intensity: bool
    period_steps: int  # a new scan every n steps; 0: every step, at the world's frequency
    resolution_unit: str = "rad"  # or "centideg"
    range_res_unit: str = "m"  # or "mm"
    fan: Fan | None = None  # rays of its own (first..last index them) instead of the world's


def whole_scan(spec: Any) -> ScanConfig:
    """The scan as the world describes it."""
    return ScanConfig(0, int(spec.samples) - 1, 1, float(spec.max_range_m),
                      float(spec.range_res_m), False, 0)


def _set(v: float) -> bool:
    """Did the client give this field (a finite value > 0, not a denormal)?"""
    return math.isfinite(v) and v > 1e-9


class OffGrid(ValueError):
    """The window or resolution asked for is not one of the simulated scan's."""


def _sick_resolution(req: ScanRequest) -> tuple[float, str] | None:
    """(rad, unit) when the request's resolution is a SICK LMS's (25, 50 or 100)."""
    if req.resolution in SICK_RESOLUTIONS:
        return math.radians(req.resolution / 100.0), "centideg"
    return None


def scan_config(spec: Any, req: ScanRequest, current: ScanConfig,
                interval_s: float) -> ScanConfig:
    """The configuration a request puts in force: a window of the simulated readings when it
    is one, else a fan of its own at a SICK resolution; ValueError when neither."""
    try:
        return _on_grid(spec, req, current, interval_s)
    except OffGrid:
        sick = _sick_resolution(req)
        if sick is None and current.fan is not None and not _set(req.resolution):
            sick = (current.fan[1], current.resolution_unit)  # the fan's, kept
        if sick is None or int(spec.samples) == 1:
            raise
        return _fan(spec, req, current, interval_s, *sick)


def _fan(spec: Any, req: ScanRequest, current: ScanConfig, interval_s: float,
         res_rad: float, unit: str) -> ScanConfig:
    lo0, hi0 = float(spec.min_angle_rad), float(spec.max_angle_rad)
    lo, hi = req.min_angle, req.max_angle
    if lo < lo0 - _FOV_SLACK or hi > hi0 + _FOV_SLACK:
        raise ValueError(f"min_angle..max_angle {math.degrees(lo):.4g}..{math.degrees(hi):.4g}"
                         f" deg is outside the field of view {math.degrees(lo0):.4g}.."
                         f"{math.degrees(hi0):.4g} deg")
    if hi < lo:
        raise ValueError("max_angle is below min_angle")
    if unit == "centideg" and res_rad < math.radians(0.5) - 1e-12 and \
            hi - lo > math.radians(100.0) + 1e-9:
        raise ValueError("a 0.25 degree resolution scans at most 100 degrees")
    n = math.floor((hi - lo) / res_rad + _TOLERANCE) + 1
    cfg = replace(current, first=0, last=n - 1, step=1, intensity=bool(req.intensity),
                  resolution_unit=unit, fan=(lo, res_rad, n))
    return _rest(spec, req, cfg, interval_s)


def _on_grid(spec: Any, req: ScanRequest, current: ScanConfig,
             interval_s: float) -> ScanConfig:
    n = int(spec.samples)
    res = float(spec.resolution_rad)
    lo0 = float(spec.min_angle_rad)
    if not (math.isfinite(req.min_angle) and math.isfinite(req.max_angle)):
        raise ValueError("min_angle and max_angle must be finite")

    def index(angle: float, what: str) -> int:
        if n == 1:
            return 0
        x = (angle - lo0) / res
        i = round(x)
        if abs(x - i) > _TOLERANCE or not 0 <= i < n:
            raise OffGrid(f"{what} {math.degrees(angle):.4g} deg is not one of the "
                             f"simulated readings ({math.degrees(lo0):.4g} to "
                             f"{math.degrees(float(spec.max_angle_rad)):.4g} deg every "
                             f"{math.degrees(res):.4g} deg)")
        return i

    first, last = index(req.min_angle, "min_angle"), index(req.max_angle, "max_angle")
    if last < first:
        raise ValueError("max_angle is below min_angle")
    cfg = replace(current, first=first, last=last, intensity=bool(req.intensity), fan=None)
    if req.resolution in SICK_RESOLUTIONS:
        if req.resolution == 25.0 and req.max_angle - req.min_angle > math.radians(100.0) + 1e-9:
            raise ValueError("a 0.25 degree resolution scans at most 100 degrees")
        res_rad, unit = math.radians(req.resolution / 100.0), "centideg"
    elif _set(req.resolution):
        res_rad, unit = req.resolution, "rad"
    elif current.fan is not None:
        res_rad, unit = current.fan[1], current.resolution_unit
    else:
        res_rad, unit = res * current.step, current.resolution_unit
    step = 1 if n == 1 else round(res_rad / res)
    if n > 1 and (step < 1 or abs(res_rad / res - step) > _TOLERANCE):
        raise OffGrid(f"resolution {math.degrees(res_rad):.4g} deg is not a whole multiple "
                         f"of the simulated {math.degrees(res):.4g} deg")
    if (last - first) % step:
        raise OffGrid(f"min_angle..max_angle is not a whole number of "
                         f"{math.degrees(res_rad):.4g} deg steps")
    return _rest(spec, req, replace(cfg, step=step, resolution_unit=unit), interval_s)


def _rest(spec: Any, req: ScanRequest, cfg: ScanConfig, interval_s: float) -> ScanConfig:
    """The range, range resolution and frequency of a request, over its angles in ``cfg``."""
    if _set(req.max_range):
        if req.max_range > float(spec.max_range_m) * (1 + 1e-6):
            raise ValueError(f"max_range {req.max_range:g} m is beyond the simulated "
                             f"{float(spec.max_range_m):g} m")
        cfg = replace(cfg, max_range_m=min(req.max_range, float(spec.max_range_m)))
    if req.range_res in SICK_RANGE_RES_MM:
        cfg = replace(cfg, range_res_m=req.range_res / 1000.0, range_res_unit="mm")
    elif _set(req.range_res):
        if not float(spec.range_res_m) * (1 - 1e-6) <= req.range_res <= 1.0:
            raise ValueError(f"range_res {req.range_res:g} m is outside "
                             f"[{float(spec.range_res_m):g}, 1] m")
        cfg = replace(cfg, range_res_m=req.range_res, range_res_unit="m")
    if _set(req.frequency_hz):
        k = 1.0 / (req.frequency_hz * interval_s)
        period = round(k)
        if period < 1 or abs(k - period) > 0.01 * k:
            raise ValueError(f"scanning_frequency {req.frequency_hz:g} Hz is not the "
                             f"simulation rate {1 / interval_s:g} Hz divided by a whole number")
        cfg = replace(cfg, period_steps=period)
    return cfg


def reported(spec: Any, cfg: ScanConfig, interval_s: float) -> tuple[float, ...]:
    """(min_angle, max_angle, resolution, max_range, range_res, frequency) as answered."""
    lo, hi, res_out = window(spec, cfg)
    if cfg.resolution_unit == "centideg":
        res_out = round(math.degrees(res_out) * 100.0)
    rr = cfg.range_res_m * 1000.0 if cfg.range_res_unit == "mm" else cfg.range_res_m
    freq = (float(spec.frequency_hz) if cfg.period_steps == 0
            else 1.0 / (cfg.period_steps * interval_s))
    return (lo, hi, res_out, cfg.max_range_m, rr, freq)


def window(spec: Any, cfg: ScanConfig) -> tuple[float, float, float]:
    """min_angle, max_angle, resolution (rad) of the readings served."""
    if cfg.fan is not None:
        lo, res, n = cfg.fan
        return lo, lo + (n - 1) * res, res
    res = float(spec.resolution_rad)
    lo = float(spec.min_angle_rad)
    return lo + cfg.first * res, lo + cfg.last * res, res * cfg.step


def apply(cfg: ScanConfig, ranges: tuple[float, ...], full: int) -> tuple[float, ...]:
    """The served ranges: the window, clipped to max range, rounded to the range resolution."""
    if cfg.fan is not None:  # cast for this configuration: every reading is served
        cut = ranges
    else:
        cut = ranges[cfg.first:cfg.last + 1:cfg.step] if len(ranges) == full else ranges
    top, q = cfg.max_range_m, cfg.range_res_m
    if q > 0.0011:
        return tuple(min(round(r / q) * q, top) for r in cut)
    return tuple(r if r <= top else top for r in cut)


def intensities(cfg: ScanConfig, ranges: tuple[float, ...]) -> bytes:
    """1 where a reading hit something (shorter than the maximum range), else 0."""
    if not cfg.intensity:
        return b""
    top = cfg.max_range_m * (1 - 1e-6)
    return bytes(1 if r < top else 0 for r in ranges)


class ConfiguredScan:
    """One scanner's configuration in force and the scan last served under it (shared by
    the laser and ranger views of the same scanner, as Player's rangertolaser shares it)."""

    def __init__(self, spec: Any, interval_s: float) -> None:
        self.spec = spec
        self.interval_s = interval_s
        self.config = whole_scan(spec)
        self._last: tuple[Any, int, tuple[float, ...], bytes] = (None, -1, (), b"")

    @property
    def is_whole(self) -> bool:
        return self.config == whole_scan(self.spec)

    def set(self, req: ScanRequest) -> None:
        """Put a request in force (ValueError, nothing changed, when impossible)."""
        self.config = scan_config(self.spec, req, self.config, self.interval_s)
        self._last = (None, -1, (), b"")

    def set_intensity(self, on: bool) -> None:
        self.config = replace(self.config, intensity=on)
        self._last = (None, -1, (), b"")

    def reported(self) -> tuple[float, ...]:
        return reported(self.spec, self.config, self.interval_s)

    def angles(self) -> tuple[float, float, float]:
        """min_angle, max_angle, resolution (rad) of the readings served."""
        return window(self.spec, self.config)

    def serve(self, reading: Any, tick: int, clean: Any) -> tuple[tuple[float, ...], bytes]:
        """The ranges and intensities for this step: made afresh from ``reading`` (through
        ``clean``) when it changed and the configured period has passed, else the last."""
        last_in, last_tick, ranges, intens = self._last
        period = self.config.period_steps
        if reading is last_in or (period > 1 and 0 <= tick - last_tick < period):
            return ranges, intens
        ranges = apply(self.config, clean(reading), int(self.spec.samples))
        intens = intensities(self.config, ranges)
        self._last = (reading, tick, ranges, intens)
        return ranges, intens
