"""Camera conventions (OpenCV, cam_from_world) and the flight patterns."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mound.errors import InputError
from mound.geometry.camera import Camera, Pose, project
from mound.geometry.flight import orbit, raster

CAM = Camera.from_fov(1280, 960, np.deg2rad(70))


def test_nadir_camera_has_north_up_and_east_right() -> None:
    pose = Pose.look_at(np.array([10.0, 20.0, 50.0]), np.array([10.0, 20.0, 0.0]))
    np.testing.assert_allclose(pose.centre, [10, 20, 50])
    np.testing.assert_allclose(pose.R @ pose.R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(pose.R) == pytest.approx(1.0)
    pts = np.array([[10.0, 20.0, 0.0], [15.0, 20.0, 0.0], [10.0, 25.0, 0.0]])
    uv, depth = project(CAM, pose, pts)
    np.testing.assert_allclose(uv[0], [CAM.cx, CAM.cy])  # straight below: principal point
    assert uv[1, 0] > CAM.cx and uv[1, 1] == pytest.approx(CAM.cy)  # east: to the right
    assert uv[2, 1] < CAM.cy and uv[2, 0] == pytest.approx(CAM.cx)  # north: up the image
    np.testing.assert_allclose(depth, [50, 50, 50])


def test_projection_equals_k_r_t() -> None:
    pose = Pose.look_at(np.array([30.0, -40.0, 25.0]), np.array([0.0, 0.0, 3.0]))
    x = np.array([[1.0, 2.0, 3.0], [-4.0, 0.5, 1.0]])
    uv, _ = project(CAM, pose, x)
    h = (CAM.K @ (pose.R @ x.T + pose.t[:, None])).T
    np.testing.assert_allclose(uv, h[:, :2] / h[:, 2:], rtol=1e-12)


def test_raster_overlaps_and_covers_the_area() -> None:
    shots = raster(CAM, (0.0, 0.0), 60.0, 40.0, altitude_m=30.0, front_overlap=0.8,
                   side_overlap=0.6)
    fw, fh = CAM.ground_footprint_m(30.0)
    centres = np.array([s.pose.centre for s in shots])
    assert np.allclose(centres[:, 2], 30.0)
    same_line = [(a, b) for a, b in itertools.pairwise(shots) if a.line == b.line]
    steps = {round(float(np.linalg.norm(a.pose.centre - b.pose.centre)), 6) for a, b in same_line}
    assert steps == {round(fh * 0.2, 6)}  # front overlap 80 %
    xs = sorted({round(float(c[0]), 6) for c in centres})
    assert np.allclose(np.diff(xs), fw * 0.4)  # side overlap 60 %
    # Every ground point of the area is seen by at least two images.
    grid = np.array([[x, y, 0.0] for x in np.linspace(-30, 30, 13)
                     for y in np.linspace(-20, 20, 9)])
    seen = np.zeros(len(grid), dtype=int)
    for s in shots:
        uv, z = project(CAM, s.pose, grid)
        seen += (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] <= CAM.width_px - 1) & \
            (uv[:, 1] >= 0) & (uv[:, 1] <= CAM.height_px - 1)
    assert seen.min() >= 2


def test_orbit_looks_at_the_centre_from_above() -> None:
    shots = orbit((5.0, 5.0, 2.0), radius_m=40.0, altitude_m=25.0, n_images=24)
    assert len(shots) == 24
    for s in shots:
        uv, z = project(CAM, s.pose, np.array([[5.0, 5.0, 2.0]]))
        np.testing.assert_allclose(uv[0], [CAM.cx, CAM.cy], atol=1e-9)
        assert z[0] > 0 and s.pose.centre[2] == pytest.approx(25.0)
        # Oblique but upright: the image y axis points downwards in the world.
        assert (s.pose.R[1] @ np.array([0, 0, 1.0])) < 0


@pytest.mark.parametrize("call", [
    lambda: raster(CAM, (0, 0), 50, 50, altitude_m=0.0),
    lambda: raster(CAM, (0, 0), 50, 50, altitude_m=-5.0),
    lambda: raster(CAM, (0, 0), 50, 50, altitude_m=30, front_overlap=0.0),
    lambda: raster(CAM, (0, 0), 50, 50, altitude_m=30, side_overlap=1.0),
    lambda: raster(CAM, (0, 0), -1, 50, altitude_m=30),
    lambda: orbit((0, 0, 0), radius_m=0, altitude_m=20, n_images=12),
    lambda: orbit((0, 0, 30), radius_m=10, altitude_m=20, n_images=12),  # below the centre
    lambda: Camera.from_fov(0, 960, 1.0),
])
def test_impossible_parameters_are_rejected(call) -> None:
    with pytest.raises(InputError):
        call()
