"""Cameras as values, and blob detection in rendered images with OpenCV (render fidelity).

The fast, geometric blobfinder lives in ``fastsense`` (BlobPlan).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from player_server.sim.readings import Blob

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class CameraPose:
    """One camera in the world (rendering uses this)."""

    x: float
    y: float
    z: float
    yaw: float
    tilt: float
    fov_h: float
    width: int
    height: int
    max_range: float


@dataclass(frozen=True)
class Cameras:
    """nc cameras as arrays: world pose, optics, blobfinder minimum area, owning body."""

    x: F64
    y: F64
    z: F64
    yaw: F64
    tilt: F64
    fov_h: F64
    width: F64
    height: F64
    max_range: F64
    min_area: F64

    def pose(self, i: int) -> CameraPose:
        return CameraPose(float(self.x[i]), float(self.y[i]), float(self.z[i]),
                          float(self.yaw[i]), float(self.tilt[i]), float(self.fov_h[i]),
                          int(self.width[i]), int(self.height[i]), float(self.max_range[i]))


def detect(
    rgb: NDArray[np.uint8],
    depth_m: F64 | None,
    channels: tuple[int, ...],
    tolerance: int,
    min_area: int,
    focal_px: float = 1.0,
) -> tuple[Blob, ...]:
    """Find blobs of each channel colour in an RGB image (CMVision-like colour thresholds)."""
    blobs: list[Blob] = []
    img = np.ascontiguousarray(rgb)
    for ch, colour in enumerate(channels):
        target = np.array([(colour >> 16) & 0xFF, (colour >> 8) & 0xFF, colour & 0xFF])
        lower = np.clip(target - tolerance, 0, 255).astype(np.uint8)
        upper = np.clip(target + tolerance, 0, 255).astype(np.uint8)
        mask = cv2.inRange(img, lower, upper)
        if cv2.countNonZero(mask) == 0:
            continue
        n, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        found = []
        for lab in range(1, n):
            x, y, bw, bh, area = (int(v) for v in stats[lab])
            if area < min_area:
                continue
            rng = 0.0
            if depth_m is not None:
                # Horizontal range: depth along the axis, stretched by the pixel's bearing.
                ys, xs = np.nonzero(labels == lab)
                stretch = np.sqrt(1.0 + ((xs - (rgb.shape[1] - 1) / 2) / focal_px) ** 2)
                rng = float(np.median(depth_m[ys, xs] * stretch))
            found.append(Blob(
                id=ch,
                colour=colour,
                area=area,
                x=round(float(centroids[lab][0])),
                y=round(float(centroids[lab][1])),
                l=x,
                r=x + bw - 1,
                t=y,
                b=y + bh - 1,
                range_m=rng,
            ))
        blobs.extend(sorted(found, key=lambda b: (-b.area, b.x)))
    return tuple(blobs)
