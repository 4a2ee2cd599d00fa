"""Figures of a simulated site: a contact sheet of its images and a 3-D plot of the true
surface with the camera poses (as the paper's Fig. 3)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, cast

import matplotlib.image as mpimg
import numpy as np

if TYPE_CHECKING:
    from mpl_toolkits.mplot3d.axes3d import Axes3D
from matplotlib.colors import LightSource, Normalize

from mound.jsonio import read_json
from mound.plotting import plt, save_figure


def contact_sheet(site_dir: str | Path, out_png: str | Path, columns: int = 8,
                  thumb_step: int = 8, dpi: int = 80) -> Path:
    """Every image of the site, downsampled by `thumb_step`, in a grid with its index."""
    site_dir = Path(site_dir)
    poses = read_json(site_dir / "poses.json", "mound.poses", 1)
    images = poses["images"]
    rows = -(-len(images) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(2.0 * columns, 1.6 * rows + 0.4),
                             squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, im in zip(axes.ravel(), images, strict=False):
        ax.imshow(mpimg.imread(site_dir / im["file"])[::thumb_step, ::thumb_step])
        ax.set_title(f"{im['id']} {im['pattern']}", fontsize=7)
    site = read_json(site_dir / "site.json", "mound.sim_site", 1)
    kind = "tumulus" if site["mound"] else "flat control"
    size = f"{site['sim']['width_px']}x{site['sim']['height_px']}"
    fig.suptitle(f"{site_dir.name}: {kind}, {len(images)} images {size}, "
                 f"seed {site['sim']['seed']}", fontsize=9)
    return save_figure(fig, out_png, dpi)


def _frustum(R: np.ndarray, t: np.ndarray, K: np.ndarray, w: int, h: int, depth: float
             ) -> np.ndarray:
    """World coordinates of the camera centre and the 4 image corners at `depth`."""
    corners = np.array([[0, 0, 1], [w - 1, 0, 1], [w - 1, h - 1, 1], [0, h - 1, 1]], float)
    rays = (np.linalg.inv(K) @ corners.T).T * depth
    centre = -R.T @ t
    return np.vstack([centre, (rays - t) @ R])  # X_world = R^T (X_cam - t)


def scene_3d(site_dir: str | Path, out_png: str | Path, grid_step: int = 8, dpi: int = 90
             ) -> Path:
    """The ground-truth surface (every `grid_step`-th vertex, hill-shaded by height) with each
    camera as a small frustum and its noisy GPS position."""
    site_dir = Path(site_dir)
    site = read_json(site_dir / "site.json", "mound.sim_site", 1)
    poses = read_json(site_dir / "poses.json", "mound.poses", 1)
    camera = read_json(site_dir / "camera.json", "mound.camera", 1)
    grid = site["heightfield"]
    z = np.load(site_dir / grid["npy"])
    ny, nx = z.shape
    x = grid["x0_m"] + grid["spacing_m"] * np.arange(nx)
    y = grid["y0_m"] + grid["spacing_m"] * np.arange(ny)
    s = grid_step
    xx, yy = np.meshgrid(x[::s], y[::s])
    zz = z[::s, ::s]
    lo, hi = float(zz.min()), float(zz.max())
    norm = Normalize(vmin=lo - 0.3 * (hi - lo + 1e-9), vmax=hi)  # green ground, brown top
    shaded = LightSource(azdeg=315, altdeg=35).shade(zz, cmap=plt.get_cmap("terrain"),
                                                     norm=norm, vert_exag=2, blend_mode="soft")
    fig = plt.figure(figsize=(9, 7))
    ax = cast("Axes3D", fig.add_subplot(projection="3d"))
    ax.plot_surface(xx, yy, zz, facecolors=shaded, rstride=1, cstride=1, linewidth=0,
                    antialiased=False, shade=False)
    K = np.array(camera["K"])
    depth = 0.12 * site["terrain"]["diameter_m"]
    for im in poses["images"]:
        R = np.array(im["cam_from_world"]["R"])
        t = np.array(im["cam_from_world"]["t"])
        fr = _frustum(R, t, K, camera["width"], camera["height"], depth)
        colour = "tab:red" if im["pattern"] == "raster" else "tab:blue"
        for k in range(1, 5):
            ax.plot(*zip(fr[0], fr[k], strict=True), color=colour, lw=0.6)
            ax.plot(*zip(fr[k], fr[1 + k % 4], strict=True), color=colour, lw=0.6)
        gx, gy, gz = im["gps_enu_m"]
        ax.scatter(gx, gy, gz, color="k", s=4)
    sigma = poses["gps_sigma_m"]
    ax.set_title(f"ground truth surface and {len(poses['images'])} camera poses "
                 f"(red raster, blue orbit; dots: GPS, sigma {sigma['horizontal']:g} m / "
                 f"{sigma['vertical']:g} m)", fontsize=9)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_zlabel("up (m)")
    top = max(im["centre_enu_m"][2] for im in poses["images"])
    ax.set_box_aspect((1, 1, (top - float(z.min())) / (x[-1] - x[0])))
    ax.view_init(elev=28, azim=-60)
    return save_figure(fig, out_png, dpi)
