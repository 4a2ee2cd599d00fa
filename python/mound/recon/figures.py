"""A picture of a reconstruction from mound_recon's outputs: the coloured sparse cloud and
every registered camera as a frustum (recon.json + points.ply)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

if TYPE_CHECKING:
    from mpl_toolkits.mplot3d.axes3d import Axes3D

from mound.errors import InputError
from mound.formats.recon import Recon
from mound.plotting import plt, save_figure
from mound.ply import read_ply


def cloud_and_cameras(recon_dir: str | Path, out_png: str | Path, max_points: int = 40000,
                      dpi: int = 90, seed: int = 0) -> Path:
    recon_dir = Path(recon_dir)
    recon = Recon.read(recon_dir / "recon.json")
    if recon.camera is None:
        raise InputError(f"{recon.path}: camera: missing (a failed reconstruction?)")
    xyz, rgb = read_ply(recon_dir / "points.ply")
    rng = np.random.default_rng(seed)
    if len(xyz) > max_points:
        keep = rng.choice(len(xyz), max_points, replace=False)
        xyz, rgb = xyz[keep], (rgb[keep] if rgb is not None else None)
    # Robust extent of the cloud, so that a few far points do not shrink the picture.
    lo, hi = np.percentile(xyz, 1, axis=0), np.percentile(xyz, 99, axis=0)
    inside = np.all((xyz >= lo) & (xyz <= hi), axis=1)
    fig = plt.figure(figsize=(8, 6))
    ax = cast("Axes3D", fig.add_subplot(projection="3d"))
    colours = rgb[inside] / 255.0 if rgb is not None else "grey"
    px, py, pz = xyz[inside].T
    ax.scatter(px, py, pz, c=colours, s=0.6, depthshade=False)
    cam = recon.camera
    w, h, k = cam.width_px, cam.height_px, cam.K
    centres = []
    size = 0.04 * float(np.linalg.norm(hi - lo))
    corners_px = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1]], dtype=float)
    rays = (np.linalg.inv(k) @ corners_px.T).T
    for _, pose, c in recon.poses():
        r = pose.R
        centres.append(c)
        corners = c + size * (r.T @ rays.T).T
        for p in corners:
            ax.plot(*np.stack([c, p]).T, color="crimson", lw=0.6)
        ax.plot(*np.vstack([corners, corners[:1]]).T, color="crimson", lw=0.6)
    allp = np.vstack([xyz[inside], np.array(centres)])
    mid, span = allp.mean(0), (allp.max(0) - allp.min(0)).max() / 2
    ax.set_xlim(mid[0] - span, mid[0] + span)
    ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(mid[2] - span, mid[2] + span)
    unit = "m" if recon.scale == "metric" else "model units"
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"y ({unit})")
    ax.set_zlabel(f"z ({unit})")
    ax.view_init(elev=28, azim=-60)
    rmse = recon.reprojection_rmse_px
    ax.set_title(f"{len(recon.poses())}/{len(recon.images)} images, {recon.points} points, "
                 f"RMSE {rmse if rmse is not None else float('nan'):.2f} px, "
                 f"frame {recon.frame}")
    return save_figure(fig, out_png, dpi)
