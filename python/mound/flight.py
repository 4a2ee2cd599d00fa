"""Flight patterns over a site: the poses the UAV camera takes its images from.

One generator for both the site simulator (what it renders) and the MAVLink mission (what
the aircraft flies), so the two agree. Positions are in the site's ENU frame (metres),
heights above the site's ground reference z = 0.

raster: a lawnmower over a rectangle centred on the site, nadir camera, lines running
  north-south, line spacing from the side overlap and image spacing from the front overlap
  of the ground footprint at the flight height.
orbit: a circle around the site at a given radius and height, the camera looking at the
  site centre (oblique views), evenly spaced images.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mound.camera import Camera, Pose
from mound.jsonio import InputError


@dataclass(frozen=True)
class Shot:
    pose: Pose
    line: int  # raster line (0-based), or 0 for an orbit


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise InputError(message)


def raster(camera: Camera, centre_xy: tuple[float, float], width_m: float, height_m: float,
           altitude_m: float, front_overlap: float = 0.75, side_overlap: float = 0.6
           ) -> list[Shot]:
    _require(width_m > 0 and height_m > 0, "raster: area width and height must be > 0")
    _require(altitude_m > 0, "raster: altitude must be > 0 m above the ground reference")
    for name, v in (("front_overlap", front_overlap), ("side_overlap", side_overlap)):
        _require(0 < v < 1, f"raster: {name} must be in (0, 1), got {v}")
    fw, fh = camera.ground_footprint_m(altitude_m)
    line_step = fw * (1 - side_overlap)
    shot_step = fh * (1 - front_overlap)
    n_lines = max(1, math.ceil(width_m / line_step) + 1)
    n_shots = max(1, math.ceil(height_m / shot_step) + 1)
    x0 = centre_xy[0] - line_step * (n_lines - 1) / 2
    y0 = centre_xy[1] - shot_step * (n_shots - 1) / 2
    shots = []
    for i in range(n_lines):
        ys = range(n_shots) if i % 2 == 0 else range(n_shots - 1, -1, -1)
        for j in ys:
            c = np.array([x0 + i * line_step, y0 + j * shot_step, altitude_m])
            shots.append(Shot(Pose.look_at(c, c - np.array([0, 0, 1.0])), i))
    return shots


def orbit(centre_xyz: tuple[float, float, float], radius_m: float, altitude_m: float,
          n_images: int) -> list[Shot]:
    _require(radius_m > 0, "orbit: radius must be > 0")
    _require(altitude_m > 0, "orbit: altitude must be > 0 m above the ground reference")
    _require(n_images >= 3, "orbit: at least 3 images")
    target = np.asarray(centre_xyz, dtype=float)
    shots = []
    for k in range(n_images):
        a = 2 * math.pi * k / n_images
        c = np.array([target[0] + radius_m * math.cos(a), target[1] + radius_m * math.sin(a),
                      altitude_m])
        _require(c[2] > target[2], "orbit: the camera must fly above the site centre")
        shots.append(Shot(Pose.look_at(c, target, up=(0.0, 0.0, 1.0)), 0))
    return shots
