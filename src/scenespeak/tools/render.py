"""Private rendering helpers of the scene generator: meshes, cameras and pybullet's TinyRenderer.

Nothing here is public API; :mod:`scenespeak.tools.scenes` is. Every call opens its own pybullet
``DIRECT`` client and disconnects it, so there is no global state and calls can run in a pool.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Camera",
    "MeshSpec",
    "capture",
    "load_bodies",
    "render",
    "render_with_depth",
    "texture_image",
    "write_box_obj",
    "write_cylinder_obj",
]

NEAR, FAR = 0.02, 60.0
CYLINDER_SEGMENTS = 48
FLOOR_RGBA = (0.62, 0.60, 0.56, 1.0)
LIGHT_DIRECTION = (0.5, -1.0, 2.0)


@dataclass(frozen=True)
class Camera:
    """A pinhole camera in the world (Z up): eye position and OpenCV axes (right, down, forward)."""

    eye: tuple[float, float, float]
    right: tuple[float, float, float]
    down: tuple[float, float, float]
    forward: tuple[float, float, float]
    image_size: tuple[int, int]
    hfov_deg: float

    @property
    def rotation(self) -> NDArray[np.float64]:
        """World-to-camera rotation (rows: right, down, forward)."""
        return np.array([self.right, self.down, self.forward], float)

    def to_camera(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points ``(N, 3)`` to this camera's OpenCV frame."""
        return (np.asarray(pts, float) - np.asarray(self.eye)) @ self.rotation.T

    def projection(self, supersample: int) -> list[float]:
        """OpenGL projection matrix (column-major) with the principal point at the image centre.

        pybullet's TinyRenderer puts NDC (0, 0) at render pixel ``(W/2, H/2 - 1)`` (measured);
        the off-centre terms shift it to ``((W-1)/2, (H-1)/2)`` of the final image after
        ``supersample`` x ``supersample`` area averaging.
        """
        w, h = self.image_size
        t = np.tan(np.radians(self.hfov_deg) / 2)
        m = np.zeros((4, 4))
        m[0, 0] = 1 / t
        m[1, 1] = w / (h * t)
        m[0, 2] = 1.0 / (supersample * w)
        m[1, 2] = 1.0 / (supersample * h)
        m[2, 2] = -(FAR + NEAR) / (FAR - NEAR)
        m[2, 3] = -2 * FAR * NEAR / (FAR - NEAR)
        m[3, 2] = -1.0
        return [float(v) for v in m.T.ravel()]

    def view(self) -> list[float]:
        """OpenGL view matrix (column-major): camera x = right, y = up, z = backward."""
        r = np.array([self.right, -np.asarray(self.down), -np.asarray(self.forward)])
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = -r @ np.asarray(self.eye)
        return [float(v) for v in m.T.ravel()]

    def intrinsics(self, supersample: int) -> NDArray[np.float64]:
        """Camera matrix K of the final image, derived from :meth:`projection`.

        With the TinyRenderer pixel convention, ``u = P00*W/2 * X/Z + (1 - P02)*W/2 + 0.5/s - 0.5``
        and ``v = P11*H/2 * Y/Z + (1 + P12)*H/2 - 0.5/s - 0.5`` (``s`` = ``supersample``).
        """
        w, h = self.image_size
        p = np.array(self.projection(supersample)).reshape(4, 4).T
        s = supersample
        fx = p[0, 0] * w / 2
        fy = p[1, 1] * h / 2
        cx = (1 - p[0, 2]) * w / 2 + 0.5 / s - 0.5
        cy = (1 + p[1, 2]) * h / 2 - 0.5 / s - 0.5
        return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])

    def project(self, pts: NDArray[np.float64], supersample: int = 2) -> NDArray[np.float64]:
        """World points to final-image pixels ``(N, 2)`` (column, row)."""
        xyz = self.to_camera(pts)
        k = self.intrinsics(supersample)
        return (xyz[:, :2] / xyz[:, 2:3]) @ k[:2, :2].T + k[:2, 2]


@dataclass(frozen=True)
class MeshSpec:
    """One textured object to render: mesh kind, size (w, d, h), texture image, pose."""

    shape: str
    size: tuple[float, float, float]
    texture: str
    position: tuple[float, float, float]
    yaw_deg: float


def texture_image(name: str) -> NDArray[np.uint8]:
    """RGB uint8 photograph ``name``: a scikit-image sample (``skimage.data.<name>()``) or a
    prefixed name (``opencv-doc:FILE``, ``mpl:FILE``, ``solid:R,G,B``; see
    :func:`scenespeak.tools.scene_configs.texture_image`)."""
    from scenespeak.tools.scene_configs import texture_image as find

    return find(name)


def _write_obj(
    path: Path, verts: list[Sequence[float]], uvs: list[Sequence[float]], normals: list, faces: list
) -> None:
    lines = [f"v {v[0]:.6f} {v[1]:.6f} {v[2]:.6f}" for v in verts]
    lines += [f"vt {t[0]:.6f} {t[1]:.6f}" for t in uvs]
    lines += [f"vn {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}" for n in normals]
    lines += ["f " + " ".join(f"{a}/{b}/{c}" for a, b, c in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")


def write_box_obj(path: Path, w: float, d: float, h: float) -> None:
    """Box with its base centre at the origin; front (-y) and back faces show the whole photo,
    the sides its left/right quarter strips, top and bottom its centre."""
    x, y, z = w / 2, d / 2, h
    faces: list[tuple[list[Sequence[float]], Sequence[float], tuple[float, ...]]] = [
        ([(-x, -y, 0), (x, -y, 0), (x, -y, z), (-x, -y, z)], (0, -1, 0), (0, 0, 1, 1)),
        ([(x, y, 0), (-x, y, 0), (-x, y, z), (x, y, z)], (0, 1, 0), (0, 0, 1, 1)),
        ([(x, -y, 0), (x, y, 0), (x, y, z), (x, -y, z)], (1, 0, 0), (0.75, 0, 1, 1)),
        ([(-x, y, 0), (-x, -y, 0), (-x, -y, z), (-x, y, z)], (-1, 0, 0), (0, 0, 0.25, 1)),
        ([(-x, -y, z), (x, -y, z), (x, y, z), (-x, y, z)], (0, 0, 1), (0.25, 0.25, 0.75, 0.75)),
        ([(-x, y, 0), (x, y, 0), (x, -y, 0), (-x, -y, 0)], (0, 0, -1), (0.25, 0.25, 0.75, 0.75)),
    ]
    verts: list[Sequence[float]] = []
    uvs: list[Sequence[float]] = []
    normals = []
    tris = []
    for k, (corners, n, (u0, v0, u1, v1)) in enumerate(faces):
        verts += corners
        uvs += [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
        normals.append(n)
        a = 4 * k + 1
        tris.append([(a, a, k + 1), (a + 1, a + 1, k + 1), (a + 2, a + 2, k + 1)])
        tris.append([(a, a, k + 1), (a + 2, a + 2, k + 1), (a + 3, a + 3, k + 1)])
    _write_obj(path, verts, uvs, normals, tris)


def cylinder_outline(r: float, n: int = CYLINDER_SEGMENTS) -> NDArray[np.float64]:
    """The ``n``-gon the cylinder mesh uses for its circle, ``(n, 2)``, counter-clockwise."""
    a = 2 * np.pi * np.arange(n) / n
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)


def write_cylinder_obj(path: Path, r: float, h: float, n: int = CYLINDER_SEGMENTS) -> None:
    """Cylinder (an ``n``-gon prism) with its base centre at the origin; the photo wraps once
    around the side, the caps show a disc of its centre."""
    verts: list[Sequence[float]] = []
    uvs: list[Sequence[float]] = []
    normals: list = []
    faces: list = []
    for i in range(n + 1):
        a = 2 * np.pi * i / n
        for zz, vv in ((0.0, 0.0), (h, 1.0)):
            verts.append((r * np.cos(a), r * np.sin(a), zz))
            uvs.append((1 - i / n, vv))
            normals.append((np.cos(a), np.sin(a), 0.0))
    for i in range(n):
        b = 2 * i + 1
        faces.append([(b, b, b), (b + 2, b + 2, b + 2), (b + 3, b + 3, b + 3)])
        faces.append([(b, b, b), (b + 3, b + 3, b + 3), (b + 1, b + 1, b + 1)])
    for zz, nz in ((h, 1.0), (0.0, -1.0)):
        verts.append((0.0, 0.0, zz))
        uvs.append((0.5, 0.5))
        normals.append((0.0, 0.0, nz))
        c = len(verts)
        for i in range(n):
            a0, a1 = 2 * np.pi * i / n, 2 * np.pi * (i + 1) / n
            for a in (a0, a1):
                verts.append((r * np.cos(a), r * np.sin(a), zz))
                uvs.append((0.5 + 0.3 * np.cos(a), 0.5 + 0.3 * np.sin(a)))
                normals.append((0.0, 0.0, nz))
            k = len(verts)
            if nz > 0:
                faces.append([(c, c, c), (k - 1, k - 1, k - 1), (k, k, k)])
            else:
                faces.append([(c, c, c), (k, k, k), (k - 1, k - 1, k - 1)])
    _write_obj(path, verts, uvs, normals, faces)


def render(
    meshes: Sequence[MeshSpec],
    cameras: Sequence[Camera],
    supersample: int = 2,
) -> list[tuple[NDArray[np.uint8], NDArray[np.int32]]]:
    """Render the meshes on a plain floor from each camera.

    Returns, per camera, the RGB image (area-averaged from ``supersample`` x the size) and the
    segmentation at render resolution (``k`` = index of ``meshes[k]``, -1 = floor/background).
    """
    return [(rgb, seg) for rgb, seg, _ in render_with_depth(meshes, cameras, supersample)]


def render_with_depth(
    meshes: Sequence[MeshSpec],
    cameras: Sequence[Camera],
    supersample: int = 2,
) -> list[tuple[NDArray[np.uint8], NDArray[np.int32], NDArray[np.float32]]]:
    """:func:`render` plus each camera's depth at render resolution.

    The depth is the camera-frame Z (metres) of the OpenGL depth buffer,
    ``Z = far near / (far - (far - near) d)``; NaN where nothing was hit.
    """
    import pybullet as p

    cid = p.connect(p.DIRECT)
    try:
        with tempfile.TemporaryDirectory(prefix="scenespeak-render-") as tmp:
            ids = load_bodies(p, cid, meshes, Path(tmp))
            return [capture(p, cid, cam, supersample, ids) for cam in cameras]
    finally:
        p.disconnect(physicsClientId=cid)


def load_bodies(p: Any, cid: int, meshes: Sequence[MeshSpec], tmpdir: Path) -> dict[int, int]:
    """Add the floor and every mesh to pybullet client ``cid`` (module ``p``), textured and posed.

    Meshes and textures are written into ``tmpdir`` (each texture once). The scene generator
    (:func:`render_with_depth`) and the sequence renderer
    (:mod:`scenespeak.tools.sequences`, which then moves the bodies frame by frame) share it.

    Returns
    -------
    dict
        pybullet body id → index into ``meshes`` (-1 for the floor), in creation order.
    """
    floor = p.createVisualShape(
        p.GEOM_BOX, halfExtents=[30, 30, 0.005], rgbaColor=FLOOR_RGBA, physicsClientId=cid
    )
    floor_id = p.createMultiBody(
        baseMass=0,
        baseVisualShapeIndex=floor,
        basePosition=[0, 0, -0.005],
        physicsClientId=cid,
    )
    ids: dict[int, int] = {floor_id: -1}
    textures: dict[str, int] = {}
    for k, m in enumerate(meshes):
        obj = tmpdir / f"mesh_{k}.obj"
        if m.shape == "cylinder":
            write_cylinder_obj(obj, m.size[0] / 2, m.size[2])
        else:
            write_box_obj(obj, *m.size)
        if m.texture not in textures:
            png = tmpdir / f"tex_{len(textures)}.png"
            cv2.imwrite(str(png), texture_image(m.texture)[:, :, ::-1])
            textures[m.texture] = p.loadTexture(str(png), physicsClientId=cid)
        vis = p.createVisualShape(p.GEOM_MESH, fileName=str(obj), physicsClientId=cid)
        body = p.createMultiBody(
            baseMass=0,
            baseVisualShapeIndex=vis,
            basePosition=list(m.position),
            baseOrientation=p.getQuaternionFromEuler([0, 0, np.radians(m.yaw_deg)]),
            physicsClientId=cid,
        )
        p.changeVisualShape(
            body,
            -1,
            textureUniqueId=textures[m.texture],
            rgbaColor=[1, 1, 1, 1],
            physicsClientId=cid,
        )
        ids[body] = k
    return ids


def capture(
    p: Any, cid: int, cam: Camera, supersample: int, ids: dict[int, int]
) -> tuple[NDArray[np.uint8], NDArray[np.int32], NDArray[np.float32]]:
    """One camera's view of client ``cid``: RGB, segmentation, depth (:func:`render_with_depth`).

    ``ids`` maps body ids to segment values (:func:`load_bodies`); other pixels are -1.
    """
    w, h = cam.image_size
    s = supersample
    res = p.getCameraImage(
        w * s,
        h * s,
        cam.view(),
        cam.projection(s),
        renderer=p.ER_TINY_RENDERER,
        shadow=0,
        lightDirection=list(LIGHT_DIRECTION),
        physicsClientId=cid,
    )
    rgba = np.reshape(np.asarray(res[2], np.uint8), (h * s, w * s, 4))
    rgb = rgba[:, :, :3].astype(np.float32).reshape(h, s, w, s, 3).mean(axis=(1, 3))
    raw = np.reshape(np.asarray(res[4], np.int64), (h * s, w * s))
    seg = np.full(raw.shape, -1, np.int32)
    for body, k in ids.items():
        seg[raw == body] = k
    buf = np.reshape(np.asarray(res[3], np.float64), (h * s, w * s))
    z = FAR * NEAR / (FAR - (FAR - NEAR) * buf)
    z[buf >= 1.0 - 1e-7] = np.nan
    return np.round(rgb).astype(np.uint8), seg, z.astype(np.float32)


def downsample_labels(seg: NDArray[np.int32], supersample: int, n: int) -> NDArray[np.uint8]:
    """Segmentation at render resolution to uint8 labels (0 = background, k+1 = object k) at
    final resolution, by majority over each ``supersample`` x ``supersample`` block."""
    hs, ws = seg.shape
    s = supersample
    h, w = hs // s, ws // s
    counts = np.stack(
        [(seg == k).reshape(h, s, w, s).sum(axis=(1, 3)) for k in range(-1, n)], axis=0
    )
    return np.argmax(counts, axis=0).astype(np.uint8)


def downsample_depth(
    seg: NDArray[np.int32], depth: NDArray[np.float32], supersample: int
) -> NDArray[np.float32]:
    """Render-resolution depth to final resolution: in each ``supersample`` x ``supersample``
    block, the mean depth of the sub-pixels of the block's majority label (so an edge pixel
    takes the depth of the surface it shows, never a mix); NaN where that surface has none."""
    hs, ws = seg.shape
    s = supersample
    h, w = hs // s, ws // s
    labels = seg.reshape(h, s, w, s).transpose(0, 2, 1, 3).reshape(h, w, s * s)
    z = depth.reshape(h, s, w, s).transpose(0, 2, 1, 3).reshape(h, w, s * s)
    ids = np.unique(labels)
    counts = np.stack([(labels == k).sum(axis=2) for k in ids], axis=0)
    major = ids[np.argmax(counts, axis=0)]
    same = labels == major[:, :, None]
    zs = np.where(same & np.isfinite(z), z, 0.0).sum(axis=2)
    n = (same & np.isfinite(z)).sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(n > 0, zs / np.maximum(n, 1), np.nan)
    return out.astype(np.float32)
