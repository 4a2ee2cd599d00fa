"""Pinhole camera in OpenCV conventions, poses as cam_from_world.

Frames: the world is the site's local ENU frame (x east, y north, z up, metres). The camera
frame is OpenCV's: x right, y down, z forward (the viewing direction). A pose is
`cam_from_world` = (R, t) with X_cam = R X_world + t; the camera centre is C = -R^T t.
Pixels: u = fx x/z + cx, v = fy y/z + cy, (0, 0) the centre of the top-left pixel.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mound.errors import InputError


@dataclass(frozen=True)
class Camera:
    width_px: int
    height_px: int
    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple[float, ...] = field(default=(0.0, 0.0, 0.0, 0.0, 0.0))  # k1 k2 p1 p2 k3

    @classmethod
    def from_fov(cls, width_px: int, height_px: int, hfov_rad: float) -> Camera:
        if not (width_px > 0 and height_px > 0):
            raise InputError("camera: image size must be positive")
        if not 0 < hfov_rad < np.pi:
            raise InputError("camera: horizontal field of view must be in (0, pi) rad")
        f = 0.5 * width_px / np.tan(0.5 * hfov_rad)
        return cls(width_px, height_px, f, f, (width_px - 1) / 2, (height_px - 1) / 2)

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])

    def ground_footprint_m(self, height_m: float) -> tuple[float, float]:
        """Width and height on flat ground of a nadir image taken `height_m` above it."""
        return height_m * self.width_px / self.fx, height_m * self.height_px / self.fy

    def to_doc(self) -> dict:
        return {"model": "opencv_pinhole", "width": self.width_px, "height": self.height_px,
                "K": self.K.tolist(), "dist_k1k2p1p2k3": list(self.dist)}

    @classmethod
    def from_doc(cls, doc: Mapping[str, Any]) -> Camera:
        """The inverse of to_doc (mound.camera, recon.json's camera); KeyError, TypeError,
        ValueError or IndexError on a malformed one (a size or focal length not positive,
        a value not finite)."""
        K = np.asarray(doc["K"], dtype=float)
        cam = cls(int(doc["width"]), int(doc["height"]), float(K[0, 0]), float(K[1, 1]),
                  float(K[0, 2]), float(K[1, 2]),
                  tuple(float(v) for v in doc.get("dist_k1k2p1p2k3", [0.0] * 5)))
        values = (cam.fx, cam.fy, cam.cx, cam.cy, *cam.dist)
        if not (cam.width_px > 0 and cam.height_px > 0 and cam.fx > 0 and cam.fy > 0
                and np.isfinite(values).all()):
            raise ValueError("width, height, fx, fy must be positive and every value finite")
        return cam


@dataclass(frozen=True)
class Pose:
    """cam_from_world rotation R (3x3) and translation t (3,)."""

    R: np.ndarray
    t: np.ndarray

    @property
    def centre(self) -> np.ndarray:
        return -self.R.T @ self.t

    @classmethod
    def look_at(cls, centre: np.ndarray, target: np.ndarray,
                up: tuple[float, float, float] = (0.0, 1.0, 0.0)) -> Pose:
        """Camera at `centre` looking at `target`; image 'up' as close to `up` as possible
        (default north, so a nadir image has north at the top and east to the right)."""
        c = np.asarray(centre, dtype=float)
        z = np.asarray(target, dtype=float) - c
        if np.linalg.norm(z) == 0:
            raise InputError("pose: target equals the camera centre")
        z /= np.linalg.norm(z)
        x = np.cross(z, up)
        if np.linalg.norm(x) < 1e-9:  # looking along `up`: image x = east, made orthogonal
            east = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
            x = east - z * (z @ east)
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        R = np.vstack([x, y, z])
        return cls(R, -R @ c)

    def to_doc(self) -> dict:
        return {"R": self.R.tolist(), "t": self.t.tolist(), "centre_enu_m": self.centre.tolist()}


def project(camera: Camera, pose: Pose, points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (n, 2) and depths (n,) of world points (n, 3); with distortion."""
    pc = points_world @ pose.R.T + pose.t
    z = pc[:, 2]
    x, y = pc[:, 0] / z, pc[:, 1] / z
    k1, k2, p1, p2, k3 = camera.dist
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([camera.fx * xd + camera.cx, camera.fy * yd + camera.cy], axis=1), z
