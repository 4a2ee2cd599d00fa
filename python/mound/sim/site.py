"""Site simulator: what the UAV camera sees over a site, with the ground truth.

`simulate(spec, out_dir)` builds the terrain (terrain.py) and its shaded texture
(appearance.py), lays out the flight (flight.py: a raster of nadir images and an orbit of
oblique ones, the same generator the MAVLink mission flies), renders every image with the
C++ z-buffer rasteriser `build/mound_render` and writes, all in the site's ENU frame
(metres, x east, y north, z up, origin at the site centre, WGS84 origin stated):

    camera.json       mound.camera v1: K, distortion (OpenCV k1 k2 p1 p2 k3), image size
    poses.json        mound.poses v1: per image cam_from_world (R, t), the true camera centre
                      and a noisy "GPS" centre (Gaussian, sigma stated in the file)
    images/NNNN.png   the rendered images (sensor noise, vignetting)
    reference.ply     the true surface as a dense point cloud (every heightfield vertex)
    heightfield.npy   the true surface as a float32 (ny, nx) array; grid in site.json
    texture.npy       the shaded texture the renderer drapes over it (uint8 RGB)
    render.json       the render job (mound.render v1), to re-render with mound_render
    site.json         mound.sim_site v1: every parameter, the file list, timings
    truth.json        mound.sim_truth v1: mound or not, what stands there (tumulus and its
                      profile, a confuser's kind, or flat), height, diameter, centre (ENU m);
                      a tumulus's relief: how far it stands out of its ground
                      (terrain.mound_relief)
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mound import native
from mound.errors import InputError
from mound.geometry import flight
from mound.geometry.camera import Camera
from mound.geometry.flight import PATTERNS, FlightLayout, ScanSpec
from mound.jsonio import write_json
from mound.ply import write_ply
from mound.sim import appearance, terrain

DEFAULT_ORIGIN = {"lat": 38.5705, "lon": 27.9862, "alt_m": 95.0}  # Bin Tepe, Manisa


@dataclass(frozen=True)
class SimSpec(FlightLayout):
    """A simulated site and its flight: the terrain, the light, the flight's layout
    (FlightLayout: None scales it to the mound diameter, the orbit looking at a third of
    the mound's height), the sensor and the GPS."""

    terrain: terrain.TerrainSpec = field(default_factory=terrain.TerrainSpec)
    lighting: appearance.Lighting = field(default_factory=appearance.Lighting)
    texel_m: float | None = None  # None: a fifth of the heightfield spacing
    noise_sigma: float = 1.5      # sensor noise, digital numbers
    vignetting: float = 0.15
    gps_sigma_h_m: float = 1.0
    gps_sigma_v_m: float = 2.0
    seed: int = 1
    origin: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_ORIGIN))
    # The flight's own scale (a survey flies the same scan over every candidate, whatever
    # stands there); None: scaled to the mound's diameter (and the orbit aimed at a third of
    # its height), as in the paper's experiment.
    scan_diameter_m: float | None = None

    @property
    def site_diameter_m(self) -> float:
        return self.scan_diameter_m if self.scan_diameter_m is not None else self.terrain.diameter_m

    def scan(self) -> ScanSpec:
        """The flight over the site (the same ScanSpec a mission flies): the layout scaled
        to the mound diameter, the orbit looking at a third of the mound's height (also
        for the flat control, which gets the same flight)."""
        return ScanSpec(
            **self.layout(), site_diameter_m=self.site_diameter_m,
            target_height_m=self.terrain.height_m / 3 if self.scan_diameter_m is None else 0.0)

    def camera(self) -> Camera:
        return self.scan().camera()

    def check(self) -> None:
        self.terrain.check()
        self.lighting.sun_vector()
        if self.pattern not in PATTERNS:
            raise InputError(f"sim: pattern must be one of {PATTERNS}, got {self.pattern!r}")
        if len(self.dist) != 5 or not all(math.isfinite(d) for d in self.dist):
            raise InputError("sim: distortion needs 5 finite coefficients k1 k2 p1 p2 k3")
        for name in ("noise_sigma", "gps_sigma_h_m", "gps_sigma_v_m"):
            if not getattr(self, name) >= 0:
                raise InputError(f"sim: {name} must be >= 0")
        if not 0 <= self.vignetting < 1:
            raise InputError("sim: vignetting must be in [0, 1)")
        if self.texel_m is not None and not self.texel_m > 0:
            raise InputError("sim: texel_m must be > 0")
        if self.scan_diameter_m is not None and not 0 < self.scan_diameter_m < 1e4:
            raise InputError("sim: scan_diameter_m must be > 0")


def shots(spec: SimSpec) -> list[tuple[str, flight.Shot]]:
    """The flight's camera poses, labelled by pattern."""
    return spec.scan().shots()


def _check_above_ground(hf: terrain.Heightfield, labelled: list[tuple[str, flight.Shot]]
                        ) -> None:
    for k, (pattern, shot) in enumerate(labelled):
        c = shot.pose.centre
        ground = float(hf.height_at(np.array([c[0]]), np.array([c[1]]))[0])
        if c[2] <= ground + 1e-6:
            raise InputError(f"sim: {pattern} image {k} at ({c[0]:.2f}, {c[1]:.2f}, "
                             f"{c[2]:.2f}) m is below the ground ({ground:.2f} m): fly higher")


def _save_npy(path: Path, array: np.ndarray) -> None:
    """np.save through a uniquely named temporary file and a rename."""
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".tmp.", suffix=".npy", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            np.save(f, array)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def simulate(spec: SimSpec, out_dir: str | Path, threads: int | None = None) -> dict[str, Any]:
    """Renders the site into `out_dir`; returns the site.json document. Parameters are
    refused before anything is written; if the simulation fails later, an `out_dir` this
    call created is removed again, so a refused or failed run leaves nothing behind."""
    spec.check()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out: {out} exists and is not a folder")
    created = not out.exists()
    try:
        return _simulate(spec, out, threads)
    except BaseException:
        if created:
            shutil.rmtree(out, ignore_errors=True)
        raise


def _simulate(spec: SimSpec, out: Path, threads: int | None) -> dict[str, Any]:
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    hf = terrain.build(spec.terrain)
    timings["terrain_s"] = time.perf_counter() - t0
    labelled = shots(spec)
    _check_above_ground(hf, labelled)
    cam = spec.camera()
    out.mkdir(parents=True, exist_ok=True)

    t0 = time.perf_counter()
    spacing = float(hf.x_m[1] - hf.x_m[0])
    texel = spec.texel_m if spec.texel_m is not None else spacing / 5
    tex = appearance.shaded_texture(hf, spec.lighting, texel, spec.seed)
    timings["texture_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    _save_npy(out / "heightfield.npy", hf.z_m.astype(np.float32))
    _save_npy(out / "texture.npy", tex)
    heightfield_doc = {"npy": "heightfield.npy", "x0_m": float(hf.x_m[0]),
                       "y0_m": float(hf.y_m[0]), "spacing_m": spacing,
                       "shape": list(hf.z_m.shape)}
    camera_doc = {"schema": "mound.camera", "version": 1, **cam.to_doc()}
    write_json(out / "camera.json", camera_doc)
    files = [f"images/{k:04d}.png" for k in range(len(labelled))]
    job = {
        "schema": "mound.render", "version": 1,
        "heightfield": heightfield_doc,
        "texture": {"npy": "texture.npy", "x0_m": float(hf.x_m[0]), "y0_m": float(hf.y_m[0]),
                    "texel_m": texel},
        "camera": cam.to_doc(),
        "images": [{"file": f, "cam_from_world": {"R": s.pose.R.tolist(), "t": s.pose.t.tolist()}}
                   for f, (_, s) in zip(files, labelled, strict=True)],
        "background_rgb": [200, 210, 225], "noise_sigma": spec.noise_sigma,
        "vignetting": spec.vignetting, "seed": spec.seed,
    }
    write_json(out / "render.json", job)
    xyz = hf.points()
    f = int(round(spacing / texel))
    write_ply(out / "reference.ply", xyz, tex[::f, ::f].reshape(-1, 3),
              comment="mound.reference v1 (ENU metres, site centre origin)")
    timings["write_s"] = time.perf_counter() - t0

    args = [str(out / "render.json"), "--out", str(out)]
    if threads:
        args += ["--threads", str(threads)]
    result = native.run_json("mound_render", args)
    timings["render_s"] = native.tool_number(result, "elapsed_s", "mound_render")
    rendered = native.tool_objects(result, "images", "mound_render")

    rng = np.random.default_rng([spec.seed, 4711])
    sigma = np.array([spec.gps_sigma_h_m, spec.gps_sigma_h_m, spec.gps_sigma_v_m])
    images = []
    for k, (f_name, (pattern, s), r) in enumerate(zip(files, labelled, rendered,
                                                      strict=True)):
        c = s.pose.centre
        images.append({
            "id": k, "file": f_name, "pattern": pattern, "line": s.line,
            "cam_from_world": {"R": s.pose.R.tolist(), "t": s.pose.t.tolist()},
            "centre_enu_m": c.tolist(), "gps_enu_m": (c + rng.normal(0, 1, 3) * sigma).tolist(),
            "covered_fraction": native.tool_number(r, "covered_fraction", "mound_render"),
        })
    write_json(out / "poses.json", {
        "schema": "mound.poses", "version": 1, "frame": "enu", "origin": spec.origin,
        "camera": "camera.json",
        "gps_sigma_m": {"horizontal": spec.gps_sigma_h_m, "vertical": spec.gps_sigma_v_m},
        "images": images})
    site = {
        "schema": "mound.sim_site", "version": 1, "frame": "enu", "origin": spec.origin,
        "mound": spec.terrain.mound,
        "terrain": asdict(spec.terrain),
        "lighting": asdict(spec.lighting),
        "sim": {k: v for k, v in asdict(spec).items() if k not in ("terrain", "lighting")},
        "heightfield": heightfield_doc,
        "texture": {"npy": "texture.npy", "texel_m": texel, "shape": list(tex.shape)},
        "files": {"camera": "camera.json", "poses": "poses.json", "reference_ply": "reference.ply",
                  "render_job": "render.json", "images": files},
        "stats": {"images": len(files), "max_height_m": float(hf.z_m.max()),
                  "reference_points": int(len(xyz)), "render_threads": result["threads"]},
        "timings": timings,
    }
    truth = spec.terrain.truth()
    if spec.terrain.mound:  # how far it stands out of its ground (the true surface's)
        truth["relief"] = terrain.mound_relief(
            hf, (spec.terrain.mound_x_m, spec.terrain.mound_y_m), spec.terrain.diameter_m)
    write_json(out / "truth.json", {"schema": "mound.sim_truth", "version": 1, "frame": "enu",
                                     "origin": spec.origin, **truth})
    write_json(out / "site.json", site)
    return site
