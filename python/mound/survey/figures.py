"""The survey report's pictures: the field map with the tour, the mission in local metres,
and per site a strip of its images, the relief map with the verdict and the hillshade and
local relief model of its GeoTIFFs (PNG files)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from scipy.stats import binned_statistic_2d

from mound.errors import InputError
from mound.formats.mission import FlightTerrain, MissionSite
from mound.formats.plan import Plan
from mound.formats.sites import Site, Sites
from mound.formats.verdict import Measurements, VerdictFile
from mound.plotting import plt, save_figure
from mound.ply import read_ply
from mound.uav.mission_items import Footprint

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")


def thumbnail_strip(images_dir: Path, out_png: Path, count: int = 8,
                    height_px: int = 96) -> Path:
    """`count` images spread over the flight, side by side at `height_px`."""
    files = sorted(p for p in Path(images_dir).iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise ValueError(f"{images_dir}: no images")
    pick = [files[int(round(k))] for k in np.linspace(0, len(files) - 1, min(count, len(files)))]
    thumbs = []
    for f in pick:
        with Image.open(f) as src:
            im = src.convert("RGB")
            w = max(1, round(im.width * height_px / im.height))
            thumbs.append(im.resize((w, height_px), Image.Resampling.LANCZOS))
    gap = 4
    strip = Image.new("RGB", (sum(t.width for t in thumbs) + gap * (len(thumbs) - 1),
                              height_px), (255, 255, 255))
    x = 0
    for t in thumbs:
        strip.paste(t, (x, 0))
        x += t.width + gap
    out_png.parent.mkdir(parents=True, exist_ok=True)
    tmp = out_png.with_name(out_png.name + ".tmp.png")
    strip.save(tmp)
    tmp.replace(out_png)
    return out_png


def _ground(coef: Sequence[float], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """mound_recon verdict's ground: z = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 (x, y
    from the site centre)."""
    c = list(coef) + [0.0] * (6 - len(coef))
    return c[0] + c[1] * x + c[2] * y + c[3] * x * x + c[4] * x * y + c[5] * y * y


def relief_map(recon_dir: Path, verdict_json: Path, out_png: Path, title: str = "",
               dpi: int = 70) -> Path:
    """Height above the fitted ground (the verdict's) of the reconstructed points, gridded
    by median, with the measured rise's base circle."""
    xyz, _ = read_ply(Path(recon_dir) / "points.ply")
    verdict = VerdictFile.read(verdict_json)
    m = verdict.measurements or Measurements()
    centre = np.array(m.site_centre_enu_m or np.median(xyz[:, :2], axis=0), dtype=float)
    radius = (m.site_radius_m if m.site_radius_m is not None
              else float(np.percentile(np.linalg.norm(xyz[:, :2] - centre, axis=1), 80)))
    d = xyz[:, :2] - centre
    inside = np.linalg.norm(d, axis=1) <= radius
    d, z = d[inside], xyz[inside, 2]
    if m.ground_coefficients is not None:
        h = z - _ground(m.ground_coefficients, d[:, 0], d[:, 1])
    else:
        h = z - np.percentile(z, 15)
    cell = m.cell_m or radius / 30
    bins = max(8, int(np.ceil(2 * radius / cell)))
    edges = np.linspace(-radius, radius, bins + 1)
    grid, _, _, _ = binned_statistic_2d(d[:, 0], d[:, 1], h, "median", bins=[edges, edges])
    fig, ax = plt.subplots(figsize=(4.2, 3.6))
    lim = max(1.0, float(np.nanpercentile(grid, 99))) if np.isfinite(grid).any() else 1.0
    im = ax.imshow(grid.T, origin="lower", extent=(-radius, radius, -radius, radius),
                   cmap="terrain", vmin=min(-0.5, float(np.nanmin(grid))) if np.isfinite(
                       grid).any() else -0.5, vmax=lim)
    fig.colorbar(im, ax=ax, label="height above ground (m)")
    rise = m.rise
    if rise is not None and rise.base_diameter_m:
        c = np.array(rise.centre_enu_m or centre, dtype=float) - centre
        r = 0.5 * rise.base_diameter_m
        t = np.linspace(0, 2 * np.pi, 100)
        ax.plot(c[0] + r * np.cos(t), c[1] + r * np.sin(t), "k--", lw=1)
        ax.text(c[0], c[1], f"{rise.height_m or 0:.1f} m", ha="center", va="center",
                fontsize=8)
    ax.set_xlabel("east of site centre (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(title or (verdict.verdict.label if verdict.verdict else ""), fontsize=9)
    return save_figure(fig, out_png, dpi)


def terrain_map(rasters_dir: Path, out_png: Path, title: str = "", dpi: int = 70) -> Path:
    """The site's orthophoto (when written), hillshade and local relief model (GeoTIFFs of
    mound.recon.rasters) side by side, in UTM metres."""
    import rasterio

    rasters_dir = Path(rasters_dir)
    ortho = None
    if (rasters_dir / "orthophoto.tif").is_file():
        with rasterio.open(rasters_dir / "orthophoto.tif") as ds:
            ortho = np.moveaxis(ds.read(), 0, 2)
    panels = []
    for name in ("hillshade", "lrm"):
        with rasterio.open(rasters_dir / f"{name}.tif") as ds:
            a = ds.read(1, masked=True).filled(np.nan)
            b = ds.bounds
            panels.append((a, (b.left, b.right, b.bottom, b.top), ds.crs.to_string()))
    n = 3 if ortho is not None else 2
    fig, axes = plt.subplots(1, n, figsize=(3.8 * n, 3.4))
    shade, extent, crs = panels[0]
    if ortho is not None:
        axes[0].imshow(ortho, extent=extent)
        axes[0].set_title("orthophoto", fontsize=9)
    axes[n - 2].imshow(shade, cmap="gray", extent=extent, vmin=0, vmax=255)
    axes[n - 2].set_title("hillshade (315°/45°)", fontsize=9)
    lrm = panels[1][0]
    lim = max(0.5, float(np.nanpercentile(np.abs(lrm), 99.5))) if np.isfinite(lrm).any() else 1
    im = axes[n - 1].imshow(lrm, cmap="RdBu_r", extent=extent, vmin=-lim, vmax=lim)
    fig.colorbar(im, ax=axes[n - 1], label="local relief (m)")
    axes[n - 1].set_title("local relief model", fontsize=9)
    for ax in axes:
        ax.set_xlabel(f"easting ({crs}, m)", fontsize=7)
        ax.ticklabel_format(useOffset=False, style="plain")
        ax.tick_params(labelsize=6)
    axes[0].set_ylabel("northing (m)", fontsize=7)
    fig.suptitle(title, fontsize=9)
    return save_figure(fig, out_png, dpi)


def field_map(sites_doc: Sites, plan: Plan | None, verdicts: dict[str, str],
              out_png: Path, dpi: int = 80) -> Path:
    """Every site coloured by p(mound), the tour, the true mounds ringed and each visited
    site's verdict (`verdicts`: id -> mound, no_mound or failed) marked."""
    sites = sites_doc.sites
    xy = np.array([s.xy for s in sites])
    p = np.array([np.nan if s.p_mound is None else s.p_mound for s in sites])
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    if plan is not None:
        pos = {w.id: (w.x_m, w.y_m) for w in plan.waypoints}
        colours = ["0.35", "tab:orange", "tab:purple", "tab:brown", "tab:pink", "tab:olive"]
        for k, f in enumerate(plan.flights):
            path = np.array([pos[i] for i in f.tour if i in pos])
            if len(path) > 2:
                what = "tour" if len(plan.flights) == 1 else f"flight {k + 1}"
                ax.plot(path[:, 0], path[:, 1], "-", color=colours[k % len(colours)], lw=1.2,
                        zorder=1, label=f"{what} ({f.cost_m:.0f} m of "
                        f"{plan.budget_m:.0f} m)")
    sc = ax.scatter(xy[:, 0], xy[:, 1], c=p, cmap="viridis", vmin=0, vmax=1, s=60,
                    zorder=2, edgecolors="none")
    fig.colorbar(sc, ax=ax, label="p(mound) from the satellite classifier")
    truth = np.array([s.truth is not None and s.truth.mound for s in sites], dtype=bool)
    if truth.any():
        ax.scatter(xy[truth, 0], xy[truth, 1], s=190, facecolors="none", edgecolors="red",
                   lw=1.5, zorder=3, label="true mound")
    for verdict, marker, colour in (("mound", "^", "orange"), ("no_mound", "x", "black"),
                                    ("failed", "s", "magenta")):
        ids = [k for k, s in enumerate(sites) if verdicts.get(s.id) == verdict]
        if ids:
            ax.scatter(xy[ids, 0], xy[ids, 1] + 0.0, marker=marker, c=colour, s=36, zorder=4,
                       label=f"3-D verdict: {verdict}")
    ax.plot(sites_doc.home.x_m, sites_doc.home.y_m, "k*", ms=14, zorder=5, label="home")
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.legend(loc="upper left", bbox_to_anchor=(0, -0.12), ncol=3, fontsize=7, frameon=False)
    ax.set_title("candidate sites, tour and verdicts", fontsize=10)
    return save_figure(fig, out_png, dpi)


def mission_map(nav_enu: np.ndarray | list[np.ndarray], footprints: list[Footprint],
                sites: list[MissionSite], out_png: Path, dpi: int = 80) -> Path:
    """The MAVLink mission's flight path in local metres, coloured by height, with the
    image footprints on the ground."""
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    for fp in footprints:
        c = fp.ring()
        ax.fill(c[:, 0], c[:, 1], color="tab:blue", alpha=0.04, lw=0)
    pts = np.asarray(nav_enu, dtype=float)
    if len(pts):
        sc = ax.scatter(pts[:, 0], pts[:, 1], c=pts[:, 2], cmap="plasma", s=4, zorder=3)
        ax.plot(pts[:, 0], pts[:, 1], "-", color="0.3", lw=0.6, zorder=2)
        fig.colorbar(sc, ax=ax, label="height above home (m)")
    for s in sites:
        ax.annotate(s.id, (s.x_m, s.y_m), fontsize=6, xytext=(3, 3),
                    textcoords="offset points")
    ax.set_aspect("equal")
    ax.set_xlabel("east of home (m)")
    ax.set_ylabel("north of home (m)")
    ax.set_title("MAVLink mission: path and image footprints", fontsize=10)
    return save_figure(fig, out_png, dpi)


def leg_profiles(terrain: FlightTerrain, out_png: Path, dpi: int = 80) -> Path:
    """Each transit leg of a mission flown over a DEM, end to end: the terrain under the
    leg (AMSL), the height flown, and the clearance asked for, so that a crew sees where a
    ridge forced a climb."""
    clearance = terrain.clearance.clearance_m
    fig, ax = plt.subplots(figsize=(8.0, 3.4))
    x0 = 0.0
    for k, leg in enumerate(terrain.legs):
        prof = leg.profile
        if prof is None:
            raise InputError(f"leg {leg.from_id} -> {leg.to_id}: no terrain profile (a "
                             "mission read back from mission.json has none)")
        d = np.asarray(prof.distance_m, dtype=float) + x0
        g = np.asarray(prof.terrain_amsl_m, dtype=float)
        ax.fill_between(d, g.min() - 5, g, color="0.75", lw=0)
        ax.plot(d, g, color="0.35", lw=0.8, label="terrain" if k == 0 else None)
        ax.plot(d, np.full_like(d, prof.flight_amsl_m), color="tab:blue", lw=1.2,
                label="flight" if k == 0 else None)
        ax.plot(d, g + clearance, ":", color="tab:red", lw=0.8,
                label=f"terrain + {clearance:g} m" if k == 0 else None)
        ax.annotate(f"{leg.from_id}→{leg.to_id}", (d[0], prof.flight_amsl_m),
                    fontsize=6, xytext=(2, 3), textcoords="offset points")
        x0 = float(d[-1]) + 20.0
    ax.set_xlabel("distance along the transit legs (m, legs end to end)")
    ax.set_ylabel("height AMSL (m)")
    ax.set_title(f"Transit legs over the DEM: lowest clearance "
                 f"{terrain.lowest_clearance_m or 0:.1f} m, energy {terrain.energy_m:.0f} m",
                 fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    return save_figure(fig, out_png, dpi)


def scene_map(run_root: Path, sites_doc: Sites, plan: Plan, out_png: Path,
              dpi: int = 80) -> Path:
    """p(mound) of each scored scene (its scene's CRS, metres from the scene's corner) with
    the candidate sites (ring: truth known to be a mound; cross: known not to be), and the
    tour's legs between the candidates of that scene."""
    import rasterio

    from mound.jsonio import staged_file

    by_dir: dict[str, list[tuple[Site, Any]]] = {}
    for s in sites_doc.sites:
        at = s.extra.get("scene")
        if isinstance(at, dict):
            by_dir.setdefault(at["scene_dir"], []).append((s, at))
    dirs = sorted(by_dir)[:4]
    fig, axes = plt.subplots(1, max(1, len(dirs)), figsize=(4.2 * max(1, len(dirs)), 4.2),
                             squeeze=False)
    order = {sid: k for k, sid in enumerate(plan.flights[0].tour)}
    im = None
    for ax, d in zip(axes[0], dirs, strict=False):
        with rasterio.open(run_root / d / "p_mound.tif") as ds:
            p = ds.read(1, masked=True)
            w, s_, e, n = ds.bounds
        im = ax.imshow(p, extent=(0, e - w, 0, n - s_), cmap="magma", vmin=0, vmax=1)
        sites = by_dir[d]
        for site, at in sites:
            x, y = at["x"] - w, at["y"] - s_
            truth = None if site.truth is None else site.truth.mound
            mark = "o" if truth else "x" if truth is False else "+"
            ax.plot(x, y, mark, color="cyan" if site.id in order else "0.7", ms=9,
                    mfc="none", mew=1.5)
            ax.annotate(str(at["rank"]), (x, y), color="white", fontsize=7,
                        xytext=(4, 4), textcoords="offset points")
        visited = [at for s, at in sorted(((s, at) for s, at in sites if s.id in order),
                                          key=lambda x: order[x[0].id])]
        if len(visited) > 1:
            ax.plot([at["x"] - w for at in visited], [at["y"] - s_ for at in visited],
                    "-", color="cyan", lw=1)
        ax.set_title(d.split("/")[-1], fontsize=9)
        ax.set_xlabel("m east")
    axes[0][0].set_ylabel("m north")
    if im is not None:
        fig.colorbar(im, ax=axes[0].tolist(), shrink=0.8, label="p(mound)")
    fig.suptitle("Candidates (rank; o known mound, x known not, + unknown) and the tour "
                 "(cyan)", fontsize=9)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    with staged_file(out_png, ".png") as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)
    return out_png
