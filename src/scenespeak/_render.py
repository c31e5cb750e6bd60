"""Private rendering helpers of :mod:`scenespeak.scenes`: meshes, textures, cameras, pybullet.

Everything here is pure: each call opens its own pybullet ``DIRECT`` client, renders with the
CPU TinyRenderer and disconnects; meshes and textures are written to a temporary folder that
the caller owns. World frame: metres, z up, the floor is ``z = 0``; the left camera stands at
``(0, 0, height)`` looking along +y, pitched down by ``pitch`` radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

#: Near and far clipping planes of the rendering cameras, metres.
NEAR = 0.02
FAR = 20.0
#: Supersampling factor: images are rendered this many times larger and area-averaged down.
SUPERSAMPLE = 2
#: The floor's colour (RGBA): plain light grey, untextured, so it gives almost no keypoints.
FLOOR_RGBA = (0.72, 0.72, 0.70, 1.0)
#: Light used for every render (pybullet's TinyRenderer lighting model).
LIGHT_DIRECTION = (0.4, -0.8, 1.0)
#: pybullet 3.2.7's TinyRenderer samples pixel corners instead of pixel centres: its images lie
#: half a pixel right of and half a pixel above the OpenGL convention (measured).
TINY_PIXEL_SHIFT = 0.5


# --------------------------------------------------------------------------------------------
# cameras


@dataclass(frozen=True)
class Camera:
    """A pinhole camera in the world: position, orthonormal axes and OpenCV intrinsics.

    ``R_cw`` has rows (right, down, forward) in world coordinates, so a world point ``P`` is
    ``R_cw @ (P - eye)`` in the camera's OpenCV frame.
    """

    eye: NDArray[np.float64]
    R_cw: NDArray[np.float64]
    width: int
    height: int
    hfov_deg: float

    @property
    def fx(self) -> float:
        """Focal length in pixels, ``(w / 2) / tan(hfov / 2)`` (fx = fy: square pixels)."""
        return (self.width / 2.0) / math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def K(self) -> NDArray[np.float64]:
        """OpenCV camera matrix with the principal point ``((w-1)/2, (h-1)/2)``."""
        f = self.fx
        return np.array(
            [[f, 0.0, (self.width - 1) / 2.0], [0.0, f, (self.height - 1) / 2.0], [0, 0, 1.0]]
        )

    def to_camera(self, P: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points (N, 3) to this camera's OpenCV frame (N, 3)."""
        return (np.asarray(P, dtype=np.float64).reshape(-1, 3) - self.eye) @ self.R_cw.T

    def project(self, P: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points (N, 3) to pixels (N, 2) (OpenCV convention: pixel centres at integers)."""
        X = self.to_camera(P)
        uvw = X @ self.K.T
        return uvw[:, :2] / uvw[:, 2:3]

    def view_matrix(self) -> list[float]:
        """OpenGL view matrix (column-major, 16 floats) for pybullet."""
        right, down, fwd = self.R_cw
        up = -down
        # OpenGL camera axes: x = right, y = up, z = backwards.
        M = np.eye(4)
        M[0, :3], M[1, :3], M[2, :3] = right, up, -fwd
        M[:3, 3] = -M[:3, :3] @ self.eye
        return [float(v) for v in M.T.reshape(-1)]

    def projection_matrix(self, scale: int = 1) -> list[float]:
        """OpenGL projection matrix (column-major) whose pixels match :attr:`K` exactly.

        A symmetric frustum: the optical axis hits the image centre, which in OpenCV's
        pixel-centre convention is ``((w-1)/2, (h-1)/2)``; ``fx = P[0,0] * w / 2`` and
        ``fy = P[1,1] * h / 2``. TinyRenderer draws everything :data:`TINY_PIXEL_SHIFT` pixels
        right of and above where OpenGL's convention puts it (measured, see
        ``tests/test_scenes.py``); the matrix moves the image back by that much, in pixels of
        the rendered size ``(scale * w, scale * h)``.
        """
        w, h = self.width, self.height
        P = np.zeros((4, 4))
        P[0, 0] = 2.0 * self.fx / w
        P[1, 1] = 2.0 * self.fx / h
        P[0, 2] = 2.0 * TINY_PIXEL_SHIFT / (scale * w)
        P[1, 2] = 2.0 * TINY_PIXEL_SHIFT / (scale * h)
        P[2, 2] = -(FAR + NEAR) / (FAR - NEAR)
        P[2, 3] = -2.0 * FAR * NEAR / (FAR - NEAR)
        P[3, 2] = -1.0
        return [float(v) for v in P.T.reshape(-1)]


def rig_cameras(
    *,
    height: float,
    pitch_deg: float,
    baseline: float,
    image_size: tuple[int, int],
    hfov_deg: float,
) -> tuple[Camera, Camera]:
    """The left and right cameras of a parallel rig: the right one ``baseline`` to the right."""
    a = math.radians(pitch_deg)
    right = np.array([1.0, 0.0, 0.0])
    fwd = np.array([0.0, math.cos(a), -math.sin(a)])
    down = np.cross(fwd, right)  # right x down = fwd  <=>  down = fwd x right
    R_cw = np.vstack([right, down, fwd])
    eye = np.array([0.0, 0.0, height])
    w, h = image_size
    left = Camera(eye, R_cw, w, h, hfov_deg)
    return left, Camera(eye + baseline * right, R_cw, w, h, hfov_deg)


def look_at_camera(
    eye: Sequence[float], target: Sequence[float], image_size: tuple[int, int], hfov_deg: float
) -> Camera:
    """A camera at ``eye`` looking at ``target`` with a horizontal right axis."""
    e = np.asarray(eye, dtype=np.float64)
    fwd = np.asarray(target, dtype=np.float64) - e
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    return Camera(e, np.vstack([right, down, fwd]), image_size[0], image_size[1], hfov_deg)


# --------------------------------------------------------------------------------------------
# meshes (OBJ with our own texture coordinates)


def box_vertices(size: Sequence[float]) -> NDArray[np.float64]:
    """The 8 corners of a box of ``size = (w, d, h)`` centred at the origin."""
    w, d, h = (float(s) / 2 for s in size)
    return np.array([[sx * w, sy * d, sz * h] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


def cylinder_vertices(size: Sequence[float], n: int = 48) -> NDArray[np.float64]:
    """Points of the rims of an upright elliptic cylinder of ``size = (w, d, h)``."""
    w, d, h = (float(s) / 2 for s in size)
    t = 2 * np.pi * np.arange(n) / n
    ring = np.column_stack([w * np.cos(t), d * np.sin(t)])
    return np.vstack([np.column_stack([ring, np.full(n, z)]) for z in (-h, h)])


def _obj_text(
    verts: list[tuple[float, float, float]],
    uvs: list[tuple[float, float]],
    normals: list[tuple[float, float, float]],
    faces: list[tuple[tuple[int, int, int], ...]],
) -> str:
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts]
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in uvs]
    lines += [f"vn {x:.6f} {y:.6f} {z:.6f}" for x, y, z in normals]
    for f in faces:
        lines.append("f " + " ".join(f"{a + 1}/{b + 1}/{c + 1}" for a, b, c in f))
    return "\n".join(lines) + "\n"


def box_obj(size: Sequence[float]) -> str:
    """OBJ text of a box centred at the origin; every face shows the whole texture upright.

    The front face looks at −y (towards a camera on the −y side looking along +y).
    """
    w, d, h = (float(s) / 2 for s in size)
    # (normal, right-in-texture axis, up-in-texture axis, half extents along them, offset)
    faces_def = [
        ((0, -1, 0), (1, 0, 0), (0, 0, 1), (w, h), d),  # front
        ((0, 1, 0), (-1, 0, 0), (0, 0, 1), (w, h), d),  # back
        ((1, 0, 0), (0, 1, 0), (0, 0, 1), (d, h), w),  # right side
        ((-1, 0, 0), (0, -1, 0), (0, 0, 1), (d, h), w),  # left side
        ((0, 0, 1), (1, 0, 0), (0, 1, 0), (w, d), h),  # top
        ((0, 0, -1), (1, 0, 0), (0, -1, 0), (w, d), h),  # bottom
    ]
    verts: list[tuple[float, float, float]] = []
    uvs: list[tuple[float, float]] = []
    normals: list[tuple[float, float, float]] = []
    faces: list[tuple[tuple[int, int, int], ...]] = []
    for n, r, u, (er, eu), off in faces_def:
        nv, rv, uv = np.array(n, float), np.array(r, float), np.array(u, float)
        base = len(verts)
        ni = len(normals)
        normals.append(tuple(nv))  # type: ignore[arg-type]
        for su, sv in ((0, 0), (1, 0), (1, 1), (0, 1)):
            p = nv * off + rv * er * (2 * su - 1) + uv * eu * (2 * sv - 1)
            verts.append(tuple(float(c) for c in p))  # type: ignore[arg-type]
            uvs.append((float(su), float(sv)))
        faces.append(((base, base, ni), (base + 1, base + 1, ni), (base + 2, base + 2, ni)))
        faces.append(((base, base, ni), (base + 2, base + 2, ni), (base + 3, base + 3, ni)))
    return _obj_text(verts, uvs, normals, faces)


def cylinder_obj(size: Sequence[float], n: int = 48) -> str:
    """OBJ text of an upright (elliptic) cylinder; the texture wraps once around its side.

    The middle of the texture faces −y (the camera), reading left to right.
    """
    w, d, h = (float(s) / 2 for s in size)
    verts: list[tuple[float, float, float]] = []
    uvs: list[tuple[float, float]] = []
    normals: list[tuple[float, float, float]] = []
    faces: list[tuple[tuple[int, int, int], ...]] = []
    for k in range(n + 1):
        u = k / n
        t = -math.pi / 2 + 2 * math.pi * (u - 0.5)
        c, s = math.cos(t), math.sin(t)
        for z, v in ((-h, 0.0), (h, 1.0)):
            verts.append((w * c, d * s, z))
            uvs.append((u, v))
        nn = np.array([c / max(w, 1e-9), s / max(d, 1e-9)])
        nn /= np.linalg.norm(nn)
        normals.append((float(nn[0]), float(nn[1]), 0.0))
    for k in range(n):
        a0, a1, b0, b1 = 2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 3
        faces.append(((a0, a0, k), (b0, b0, k + 1), (b1, b1, k + 1)))
        faces.append(((a0, a0, k), (b1, b1, k + 1), (a1, a1, k)))
    # caps: the texture seen from above / below, squeezed into the ellipse
    for z, nz in ((h, 1.0), (-h, -1.0)):
        ni = len(normals)
        normals.append((0.0, 0.0, nz))
        centre = len(verts)
        verts.append((0.0, 0.0, z))
        uvs.append((0.5, 0.5))
        for k in range(n):
            t = 2 * math.pi * k / n
            verts.append((w * math.cos(t), d * math.sin(t), z))
            uvs.append((0.5 + 0.5 * math.cos(t), 0.5 + 0.5 * math.sin(t)))
        for k in range(n):
            i, j = centre + 1 + k, centre + 1 + (k + 1) % n
            tri = (i, j) if nz > 0 else (j, i)
            faces.append(((centre, centre, ni), (tri[0], tri[0], ni), (tri[1], tri[1], ni)))
    return _obj_text(verts, uvs, normals, faces)


# --------------------------------------------------------------------------------------------
# textures


def texture_image(name: str, max_side: int = 512) -> NDArray[np.uint8]:
    """An RGB uint8 photograph shipped with scikit-image (``skimage.data.<name>()``)."""
    from skimage import data

    img = np.asarray(getattr(data, name)())
    if img.dtype != np.uint8:
        img = img.astype(np.float64)
        lo, hi = float(img.min()), float(img.max())
        img = ((img - lo) / max(hi - lo, 1e-12) * 255).round().astype(np.uint8)
    if img.ndim == 2:
        img = np.stack([img] * 3, axis=-1)
    img = img[..., :3]
    s = max_side / max(img.shape[:2])
    if s < 1:
        img = cv2.resize(img, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
    return np.ascontiguousarray(img)


def write_png(path: Path, rgb: NDArray[np.uint8]) -> None:
    """Write an RGB (or grey) uint8 image as PNG, raising ``OSError`` if OpenCV cannot."""
    img = rgb if rgb.ndim == 2 else cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    if not cv2.imwrite(str(path), img):
        raise OSError(f"{path}: could not write the PNG file")


# --------------------------------------------------------------------------------------------
# rendering


@dataclass(frozen=True)
class Body:
    """A rigid textured object to render: mesh file, texture file, world pose."""

    mesh: Path
    texture: Path
    position: tuple[float, float, float]
    yaw: float  # radians about the world z axis


def downsample_rgb(img: NDArray[np.uint8], f: int) -> NDArray[np.uint8]:
    """Area-average an RGB image by an integer factor ``f``."""
    if f == 1:
        return img
    h, w = img.shape[0] // f, img.shape[1] // f
    x = img[: h * f, : w * f].reshape(h, f, w, f, -1).astype(np.float64).mean(axis=(1, 3))
    return np.clip(np.rint(x), 0, 255).astype(np.uint8)


def downsample_labels(seg: NDArray[np.int64], f: int, n_labels: int) -> NDArray[np.int64]:
    """Block-mode of an integer label image (0..n_labels) by an integer factor ``f``."""
    if f == 1:
        return seg
    h, w = seg.shape[0] // f, seg.shape[1] // f
    blocks = seg[: h * f, : w * f].reshape(h, f, w, f)
    counts = np.stack([(blocks == k).sum(axis=(1, 3)) for k in range(n_labels + 1)])
    return counts.argmax(axis=0)


def render(
    bodies: Sequence[Body],
    cameras: Sequence[Camera],
    *,
    floor: bool = True,
    supersample: int = SUPERSAMPLE,
) -> list[tuple[NDArray[np.uint8], NDArray[np.int64]]]:
    """Render ``bodies`` seen by each camera: (RGB image, label image at full render size).

    The label image holds ``i + 1`` where body ``i`` is seen, 0 elsewhere, at ``supersample``
    times the camera's resolution (before downsampling); the RGB image is area-averaged to the
    camera's resolution.
    """
    import pybullet as p

    cid = p.connect(p.DIRECT)
    try:
        uid_to_index: dict[int, int] = {}
        if floor:
            vs = p.createVisualShape(
                p.GEOM_BOX, halfExtents=[6, 6, 0.005], rgbaColor=FLOOR_RGBA, physicsClientId=cid
            )
            p.createMultiBody(0, -1, vs, [0, 3, -0.005], physicsClientId=cid)
        textures: dict[Path, int] = {}
        for i, b in enumerate(bodies):
            vs = p.createVisualShape(
                p.GEOM_MESH, fileName=str(b.mesh), meshScale=[1, 1, 1], physicsClientId=cid
            )
            orn = p.getQuaternionFromEuler([0, 0, b.yaw])
            uid = p.createMultiBody(0, -1, vs, list(b.position), orn, physicsClientId=cid)
            if b.texture not in textures:
                textures[b.texture] = p.loadTexture(str(b.texture), physicsClientId=cid)
            p.changeVisualShape(
                uid,
                -1,
                textureUniqueId=textures[b.texture],
                rgbaColor=[1, 1, 1, 1],
                physicsClientId=cid,
            )
            uid_to_index[uid] = i + 1
        out = []
        for cam in cameras:
            W, H = cam.width * supersample, cam.height * supersample
            r = p.getCameraImage(
                W,
                H,
                cam.view_matrix(),
                cam.projection_matrix(supersample),
                lightDirection=list(LIGHT_DIRECTION),
                shadow=0,
                renderer=p.ER_TINY_RENDERER,
                                physicsClientId=cid,
            )
            rgba = np.reshape(np.asarray(r[2], dtype=np.uint8), (H, W, 4))
            raw = np.reshape(np.asarray(r[4], dtype=np.int64), (H, W))
            obj = np.where(raw >= 0, raw & ((1 << 24) - 1), -1)
            seg = np.zeros((H, W), dtype=np.int64)
            for uid, idx in uid_to_index.items():
                seg[obj == uid] = idx
            out.append((downsample_rgb(np.ascontiguousarray(rgba[..., :3]), supersample), seg))
        return out
    finally:
        p.disconnect(physicsClientId=cid)
