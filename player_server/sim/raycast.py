"""A vectorised 2-D ray caster over one-sided faces (pure numpy): the general reference.

The simulation casts with ``footprint_cast`` (whole rectangles and circles, culled per ray,
in float64); this caster handles arbitrary faces densely in float32 and serves as the
independent reference it is tested against.

Footprints are one-sided faces (segments with an outward normal) and circles. A face is hit
only from its front side, so a ray that starts inside a convex footprint (a sensor inside its
own robot's body) passes out through it unseen; the arena walls are faces whose normals point
into the room.

All rays of a tick are cast in one go: one matrix product ``X @ W`` evaluates, for every ray
and every face, the signed distance of the ray origin to the face plane, the closing speed,
and the position along the face, then a handful of elementwise operations find the nearest
hit. Every face and circle carries the height of its top; a ray at height z ignores footprints
lower than z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
_FAR = 1e30
_FAR32_BITS = np.float32(1e30).view(np.uint32)
_ONE32 = np.float32(1.0)
_ZERO32 = np.float32(0.0)


@dataclass(frozen=True)
class Faces:
    """n faces: midpoint (mx, my), outward unit normal (nx, ny), half length h, top height."""

    mx: F64
    my: F64
    nx: F64
    ny: F64
    half: F64
    top: F64

    @property
    def count(self) -> int:
        return int(self.mx.shape[0])

    @staticmethod
    def empty() -> Faces:
        z = np.zeros(0)
        return Faces(z, z, z, z, z, z)

    @staticmethod
    def concat(parts: list[Faces]) -> Faces:
        parts = [p for p in parts if p.count]
        if not parts:
            return Faces.empty()
        if len(parts) == 1:
            return parts[0]
        return Faces(
            *(np.concatenate([getattr(p, f) for p in parts])
              for f in ("mx", "my", "nx", "ny", "half", "top"))
        )


@dataclass(frozen=True)
class Circles:
    cx: F64
    cy: F64
    r: F64
    top: F64

    @property
    def count(self) -> int:
        return int(self.cx.shape[0])

    @staticmethod
    def empty() -> Circles:
        z = np.zeros(0)
        return Circles(z, z, z, z)

    @staticmethod
    def concat(parts: list[Circles]) -> Circles:
        parts = [p for p in parts if p.count]
        if not parts:
            return Circles.empty()
        if len(parts) == 1:
            return parts[0]
        return Circles(*(np.concatenate([getattr(p, f) for p in parts])
                         for f in ("cx", "cy", "r", "top")))


def rectangle_faces(
    cx: F64, cy: F64, yaw: F64, half_x: F64, half_y: F64, top: F64
) -> Faces:
    """The four outward faces of each of k rectangles (vectorised; 4k faces)."""
    c, s = np.cos(yaw), np.sin(yaw)
    # Outward normals: +x axis, +y axis, -x axis, -y axis of each rectangle.
    nx = np.concatenate([c, -s, -c, s])
    ny = np.concatenate([s, c, -s, -c])
    extent_n = np.concatenate([half_x, half_y, half_x, half_y])
    half = np.concatenate([half_y, half_x, half_y, half_x])
    cx4 = np.tile(cx, 4)
    cy4 = np.tile(cy, 4)
    return Faces(
        mx=cx4 + nx * extent_n,
        my=cy4 + ny * extent_n,
        nx=nx,
        ny=ny,
        half=half,
        top=np.tile(top, 4),
    )


def arena_faces(half_x: float, half_y: float, top: float) -> Faces:
    """The inner faces of the room's walls (normals point into the room)."""
    return Faces(
        mx=np.array([half_x, 0.0, -half_x, 0.0]),
        my=np.array([0.0, half_y, 0.0, -half_y]),
        nx=np.array([-1.0, 0.0, 1.0, 0.0]),
        ny=np.array([0.0, -1.0, 0.0, 1.0]),
        half=np.array([half_y, half_x, half_y, half_x]),
        top=np.full(4, top),
    )


def face_matrix(f: Faces) -> F64:
    """W (5, 4, n) so that [ox, oy, 1, dx, dy] @ W gives, per face, four rows:
    front distance of the origin n.(o - m), closing speed -n.d, normalised position along
    the face at the origin t.(o - m)/h, and its rate along the ray t.d/h."""
    n = f.count
    tx, ty = -f.ny, f.nx
    inv_h = 1.0 / f.half
    w = np.zeros((5, 4, n))
    w[0, 0] = f.nx
    w[1, 0] = f.ny
    w[2, 0] = -(f.nx * f.mx + f.ny * f.my)
    w[3, 1] = -f.nx
    w[4, 1] = -f.ny
    w[0, 2] = tx * inv_h
    w[1, 2] = ty * inv_h
    w[2, 2] = -(tx * f.mx + ty * f.my) * inv_h
    w[3, 3] = w[0, 2]
    w[4, 3] = w[1, 2]
    return w


def write_rectangle_matrix(
    w: F64, cx: F64, cy: F64, yaw: F64, half_x: F64, half_y: F64
) -> None:
    """Fill w (5, 4, 4k) with the face matrix of k rectangles (faces ordered as in
    ``rectangle_faces``), in place and without temporaries of face size."""
    k = cx.shape[0]
    if k == 0:
        return
    c, s = np.cos(yaw), np.sin(yaw)
    p = c * cx + s * cy  # centre along the rectangle's x axis
    q = c * cy - s * cx  # centre along its y axis
    nx = np.concatenate([c, -s, -c, s])
    ny = np.concatenate([s, c, -s, -c])
    ext = np.concatenate([half_x, half_y, half_x, half_y])
    inv_h = 1.0 / np.concatenate([half_y, half_x, half_y, half_x])
    n_dot_c = np.concatenate([p, q, -p, -q])
    t_dot_c = np.concatenate([q, -p, -q, p])
    w[:] = 0.0
    w[0, 0] = nx
    w[1, 0] = ny
    w[2, 0] = -n_dot_c - ext
    w[3, 1] = -nx
    w[4, 1] = -ny
    w[0, 2] = -ny * inv_h
    w[1, 2] = nx * inv_h
    w[2, 2] = -t_dot_c * inv_h
    w[3, 3] = w[0, 2]
    w[4, 3] = w[1, 2]


def _circle_matrix(c: Circles) -> F64:
    """W (5, 2m) so that [ox, oy, 1, dx, dy] @ W = [|c|^2 - 2 c.o, c.d]."""
    m = c.count
    w = np.zeros((5, 2 * m))
    w[0, :m] = -2.0 * c.cx
    w[1, :m] = -2.0 * c.cy
    w[2, :m] = c.cx * c.cx + c.cy * c.cy
    w[3, m:] = c.cx
    w[4, m:] = c.cy
    return w


@dataclass(frozen=True)
class Scene2D:
    """Footprints ready for casting: face matrix (5, 4, n), face tops, circles."""

    w: F64
    top: F64
    circles: Circles

    @staticmethod
    def build(face_parts: list[tuple[F64, F64]], circles: Circles) -> Scene2D:
        """From (face matrix, tops) parts, e.g. precomputed static faces plus moving ones."""
        parts = [p for p in face_parts if p[1].size]
        if not parts:
            return Scene2D(np.zeros((5, 4, 0)), np.zeros(0), circles)
        if len(parts) == 1:
            return Scene2D(parts[0][0], parts[0][1], circles)
        return Scene2D(
            np.concatenate([p[0] for p in parts], axis=2),
            np.concatenate([p[1] for p in parts]),
            circles,
        )

    @staticmethod
    def from_faces(faces: Faces, circles: Circles) -> Scene2D:
        return Scene2D(face_matrix(faces), faces.top, circles)


class RayCaster:
    """Casts batches of rays; owns reusable work buffers (fresh large temporaries each call
    cost more in page faults than the arithmetic itself)."""

    def __init__(self) -> None:
        self._buffers: dict[str, np.ndarray] = {}

    def _buf(self, name: str, shape: tuple[int, int], dtype: type) -> np.ndarray:
        b = self._buffers.get(name)
        size = shape[0] * shape[1]
        if b is None or b.size < size:
            b = np.empty(max(size, 1024), dtype=dtype)
            self._buffers[name] = b
        return b[:size].reshape(shape)

    def cast(
        self,
        ox: F64,
        oy: F64,
        dx: F64,
        dy: F64,
        max_range: F64,
        z: F64,
        faces: Faces,
        circles: Circles,
    ) -> F64:
        """Distance along each unit ray to the nearest footprint at least as tall as its z.

        Rays are given by origin (ox, oy), unit direction (dx, dy) and height z; a ray that
        hits nothing within max_range returns max_range.
        """
        return self.cast_scene(ox, oy, dx, dy, max_range, z, Scene2D.from_faces(faces, circles))

    def cast_scene(
        self, ox: F64, oy: F64, dx: F64, dy: F64, max_range: F64, z: F64, scene: Scene2D
    ) -> F64:
        """As ``cast``, over a prepared Scene2D."""
        out = np.array(max_range, dtype=np.float64, copy=True)
        if out.size == 0:
            return out
        circles = scene.circles
        z_max = float(z.max())
        if (scene.top.size == 0 or float(scene.top.min()) >= z_max) and (
            circles.count == 0 or float(circles.top.min()) >= z_max
        ):
            return self._cast_group(ox, oy, dx, dy, scene.w, circles, out)
        # Rays at different heights see different footprints; heights that see the same set
        # are cast together.
        heights = np.unique(z)
        groups: dict[bytes, list[float]] = {}
        masks: dict[bytes, tuple[NDArray[np.bool_], NDArray[np.bool_]]] = {}
        for zh in heights.tolist():
            fsel = scene.top >= zh
            csel = circles.top >= zh
            key = fsel.tobytes() + b"|" + csel.tobytes()
            groups.setdefault(key, []).append(zh)
            masks[key] = (fsel, csel)
        for key, zs in groups.items():
            fsel, csel = masks[key]
            w = scene.w if fsel.all() else scene.w[:, :, fsel]
            c = circles if csel.all() else _select_circles(circles, csel)
            if len(groups) == 1:
                out = self._cast_group(ox, oy, dx, dy, w, c, out)
            else:
                idx = np.nonzero(np.isin(z, zs))[0]
                out[idx] = self._cast_group(ox[idx], oy[idx], dx[idx], dy[idx], w, c, out[idx])
        return out

    def _cast_group(
        self, ox: F64, oy: F64, dx: F64, dy: F64, w3: F64, c: Circles, limit: F64
    ) -> F64:
        # Layout (footprints x rays): per-footprint constants broadcast down columns and the
        # nearest hit is a reduction over the short first axis (fast in numpy). Faces and
        # circles share one matrix product.
        n_rays = ox.shape[0]
        n = w3.shape[2]
        k = c.count
        best = np.array(limit, dtype=np.float64, copy=True)
        if n == 0 and k == 0:
            return best
        x = np.empty((5, n_rays), dtype=np.float32)
        x[0] = ox
        x[1] = oy
        x[2] = 1.0
        x[3] = dx
        x[4] = dy
        w = np.empty((4 * n + 2 * k, 5), dtype=np.float32)
        w[:4 * n] = w3.reshape(5, 4 * n).T
        if k:
            w[4 * n:] = _circle_matrix(c).T
        m = self._buf("m", (4 * n + 2 * k, n_rays), np.float32)
        _matmul_single_thread(w, x, m)
        rows = n + k
        lam = self._buf("lam", (rows, n_rays), np.float32)
        miss = self._buf("miss", (rows, n_rays), np.bool_)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if n:
                s = self._buf("s", (n, n_rays), np.float32)
                # Faces the ray is not closing on (edge-on, or seen from behind) get a closing
                # speed of 0: their distance becomes +-inf or nan, which sort last below.
                np.maximum(m[n:2 * n], _ZERO32, out=lam[:n])
                np.divide(m[:n], lam[:n], out=lam[:n])
                np.multiply(lam[:n], m[3 * n:4 * n], out=s)
                np.add(s, m[2 * n:3 * n], out=s)
                np.abs(s, out=s)
                np.greater(s, _ONE32, out=miss[:n])  # the hit point lies off the face
            if k:
                o = 4 * n
                od = x[0] * x[3] + x[1] * x[4]
                oo = x[0] * x[0] + x[1] * x[1]
                b = np.subtract(m[o + k:o + 2 * k], od, out=m[o + k:o + 2 * k])  # (c - o).d
                disc = np.multiply(b, b, out=lam[n:])
                disc -= m[o:o + k]
                disc -= oo
                disc += (c.r * c.r).astype(np.float32)[:, None]  # r^2 - distance^2 to line
                np.less(disc, _ZERO32, out=miss[n:])  # the line passes the circle by
                np.maximum(disc, _ZERO32, out=disc)
                np.sqrt(disc, out=disc)
                np.subtract(b, disc, out=lam[n:])  # distance to the near intersection
        # Misses get their sign bit set; then, read as unsigned integers, float32 bit
        # patterns order non-negative distances correctly and put every negative value
        # (misses, footprints behind the origin) above them all; +-inf and nan sort high too.
        # (Cheaper than a masked assignment, which takes a slow path in numpy.)
        bits = self._buf("bits", (rows, n_rays), np.uint32)
        lam_bits = lam.view(np.uint32)
        np.left_shift(miss, 31, out=bits, dtype=np.uint32)
        np.bitwise_or(lam_bits, bits, out=lam_bits)
        nearest_bits = lam_bits.min(axis=0)
        np.minimum(nearest_bits, _FAR32_BITS, out=nearest_bits)  # no hit at all: _FAR
        np.minimum(best, nearest_bits.view(np.float32), out=best)
        return best


# OpenBLAS runs a product on several threads above m*n*k = 4 * 65536; its worker threads then
# spin and starve the elementwise work that follows on a busy machine. Chunk below that.
_GEMM_SINGLE_THREAD_LIMIT = 200_000


def _matmul_single_thread(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    rows = a.shape[0]
    per_row = max(1, b.shape[0] * b.shape[1])
    chunk = max(1, _GEMM_SINGLE_THREAD_LIMIT // per_row)
    if rows <= chunk:
        np.matmul(a, b, out=out)
        return
    for start in range(0, rows, chunk):
        stop = min(rows, start + chunk)
        np.matmul(a[start:stop], b, out=out[start:stop])


def _select_circles(c: Circles, sel: NDArray[np.bool_]) -> Circles:
    return Circles(c.cx[sel], c.cy[sel], c.r[sel], c.top[sel])
