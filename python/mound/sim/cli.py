"""`mound sim site|flight|figures`: the site simulator (`mound sim grid` is mound.grids')."""

from __future__ import annotations

import argparse
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from mound.args import Commands, command_group
from mound.bounds import (
    HEIGHT_M,
    IMAGE_PX,
    SEED,
    SIM_SEED,
    SITE_DIAMETER_M,
    SPEED_M_S,
    THREADS,
    Bound,
)
from mound.errors import InputError
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.jsonio import write_json

# The simulator's sizes of pits, trenches and confusers, and their azimuths (m or degrees).
SIM_SIZE_M = Bound(-1_000, 1_000)


def cmd_sim_site(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from mound.sim import site as sim
    from mound.sim import terrain
    from mound.sim.appearance import Lighting

    overrides: dict[str, Any] = {"mound": args.mound == "tumulus", "seed": args.seed}
    for key in ("profile", "diameter_m", "height_m", "erosion_m", "size_m", "resolution_m"):
        if getattr(args, key) is not None:
            overrides[key] = getattr(args, key)
    if args.pit:
        overrides.update(pit_radius_m=args.pit[0], pit_depth_m=args.pit[1],
                         pit_offset_m=args.pit[2])
    if args.offset:
        overrides.update(mound_x_m=args.offset[0], mound_y_m=args.offset[1])
    if args.trench:
        overrides.update(trench_width_m=args.trench[0], trench_depth_m=args.trench[1],
                         trench_azimuth_deg=args.trench[2])
    if args.slope:
        overrides.update(slope_deg=args.slope[0], slope_azimuth_deg=args.slope[1])
    if args.dem:
        try:
            x, y = float(args.dem[1]), float(args.dem[2])
        except ValueError:
            raise InputError("--dem: expected PATH X Y (the patch's centre in the DEM's CRS)"
                             ) from None
        overrides.update(dem_path=args.dem[0], dem_x_m=x, dem_y_m=y)
    if args.confuser:
        if args.mound != "none":
            raise InputError("--confuser: only on a site without a mound (--mound none)")
        length, width, height, az = args.confuser_size
        overrides["confusers"] = (terrain.Confuser(args.confuser, 0.0, 0.0, length, width,
                                                   height, az, count=args.trees,
                                                   seed=args.seed),)
    spec = sim.SimSpec(
        terrain=terrain.preset(args.preset, **overrides),
        lighting=Lighting(np.deg2rad(args.sun[0]), np.deg2rad(args.sun[1])),
        width_px=args.size[0], height_px=args.size[1], hfov_rad=np.deg2rad(args.hfov_deg),
        dist=tuple(args.distortion), pattern=args.pattern,
        noise_sigma=args.noise_sigma, vignetting=args.vignetting,
        gps_sigma_h_m=args.gps_sigma[0], gps_sigma_v_m=args.gps_sigma[1], seed=args.seed)
    if args.altitude is not None:
        spec = replace(spec, raster_altitude_m=args.altitude)
    if args.orbit_images is not None:
        spec = replace(spec, orbit_images=args.orbit_images)
    if args.scan_diameter is not None:
        spec = replace(spec, scan_diameter_m=args.scan_diameter)
    if args.gps_latency and not args.jpeg:
        raise InputError("--gps-latency goes with --jpeg (it moves the EXIF GPS)")
    site = sim.simulate(spec, args.out, threads=args.threads)
    if args.jpeg:
        from mound.sim.card import site_jpegs

        site_jpegs(args.out, _start_time(args.start_time), gps_latency_s=args.gps_latency,
                   style=args.exif_style)
    t = site["timings"]
    print(f"{'tumulus' if spec.terrain.mound else 'flat control'} ({args.preset}, seed "
          f"{args.seed}): {site['stats']['images']} images {spec.width_px}x{spec.height_px} "
          f"-> {args.out}")
    print(f"terrain {t['terrain_s']:.2f} s, texture {t['texture_s']:.2f} s, render "
          f"{t['render_s']:.2f} s ({site['stats']['render_threads']} threads)")
    if args.figures:
        cmd_sim_figures(argparse.Namespace(site=args.out, out_dir=args.out, dpi_scale=1.0))
    return 0


def _start_time(text: str) -> datetime:

    try:
        return datetime.fromisoformat(text)
    except ValueError:
        raise InputError(f"--start-time: expected YYYY-MM-DDTHH:MM:SS, got {text!r}") from None


def cmd_sim_flight(args: argparse.Namespace) -> int:
    from mound.sim.card import CardSpec, write_card

    sites = args.sites or str(Path(args.plan).with_name("sites.json"))
    spec = CardSpec(start=_start_time(args.start_time), speed_mps=args.speed,
                    transit_every_s=args.transit_every_s, sim_seed=args.sim_seed,
                    image_size=tuple(args.image_size), pattern=args.scan_pattern,
                    site_diameter_m=args.site_diameter_m, threads=args.threads,
                    scan_factor=args.scan_factor)
    truth = write_card(args.plan, sites, args.out, spec)
    if args.truth:
        write_json(args.truth, truth.to_doc())
    n_transit = sum(1 for f in truth.files if f.reason == "transit")
    n_sites = len({f.site for f in truth.files if f.site})
    print(f"{len(truth.files)} photos ({n_sites} sites, {n_transit} transit) -> "
          f"{args.out}/DCIM/100MEDIA")
    return 0


def terrain_confusers() -> tuple[str, ...]:
    from mound.sim.terrain import CONFUSERS

    return CONFUSERS


def cmd_sim_figures(args: argparse.Namespace) -> int:
    from mound.sim import figures as sim_figures

    out = Path(args.out_dir or args.site)
    scale = args.dpi_scale
    a = sim_figures.contact_sheet(args.site, out / "contact_sheet.png", dpi=int(80 * scale))
    b = sim_figures.scene_3d(args.site, out / "scene_3d.png", dpi=int(90 * scale))
    print(f"-> {a}, {b}")
    return 0


def add_parser(sub: Any, parser_class: Any) -> Commands[argparse.ArgumentParser]:
    """The `sim` command group; returns its subparsers (mound.grids.cli adds `grid`)."""
    simp = command_group(sub, "sim", "site simulator (images with ground truth)", parser_class)
    st = simp.add_parser("site", help="render a site's flight with its ground truth")
    st.add_argument("--preset", choices=("bin_tepe", "lab"), default="bin_tepe")
    st.add_argument("--mound", choices=("tumulus", "none"), default="tumulus",
                    help="none: the flat control (same ground, texture and flight)")
    st.add_argument("--profile", choices=("conical", "spherical_cap", "drum", "ploughed"))
    st.add_argument("--diameter", dest="diameter_m", type=SITE_DIAMETER_M.arg(), help="m")
    st.add_argument("--height", dest="height_m", type=Bound(0, 200, "m").arg(), help="m")
    st.add_argument("--erosion", dest="erosion_m", type=Bound(0, 200, "m").arg(), help="m")
    st.add_argument("--site-size", dest="size_m", type=Bound(0, 5_000, "m", above=True).arg(),
                    help="side of the site, m")
    st.add_argument("--resolution", dest="resolution_m", type=Bound(0.01, 100, "m").arg(),
                    help="grid spacing, m")
    st.add_argument("--pit", type=SIM_SIZE_M.arg(), nargs=3, metavar=("RADIUS", "DEPTH", "OFFSET"),
                    help="a looters' pit, m")
    st.add_argument("--trench", type=SIM_SIZE_M.arg(),
                    nargs=3, metavar=("WIDTH", "DEPTH", "AZIMUTH_DEG"),
                    help="a looters' trench through the top, m")
    st.add_argument("--offset", type=Bound(-5_000, 5_000, "m").arg(),
                    nargs=2, metavar=("EAST_M", "NORTH_M"),
                    help="the mound's centre off the site centre")
    st.add_argument("--slope", type=Bound(-360, 360, "deg").arg(),
                    nargs=2, metavar=("DEG", "AZIMUTH_DEG"),
                    help="ground rising towards the azimuth")
    st.add_argument("--dem", nargs=3, metavar=("DEM.tif", "X", "Y"),
                    help="real ground: the DEM's patch centred on X, Y (its CRS)")
    st.add_argument("--confuser", choices=terrain_confusers(),
                    help="something that is not a tumulus, at the site centre (--mound none)")
    st.add_argument("--confuser-size", type=SIM_SIZE_M.arg(),
                    nargs=4, default=(40.0, 10.0, 3.0, 0.0),
                    metavar=("LENGTH", "WIDTH", "HEIGHT", "AZIMUTH_DEG"))
    st.add_argument("--trees", type=Bound(0, 1_000, integer=True).arg(),
                    default=6, help="crowns in a group of trees")
    st.add_argument("--scan-diameter", type=SITE_DIAMETER_M.arg(),
                    help="the flight's own scale, m (default: the mound's diameter)")
    st.add_argument("--seed", type=SEED.arg(), default=1)
    st.add_argument("--out", required=True)
    st.add_argument("--pattern", choices=("raster", "orbit", "both"), default="both")
    st.add_argument("--size", type=IMAGE_PX.arg(), nargs=2, default=(1280, 960), metavar=("W", "H"))
    st.add_argument("--hfov-deg", type=Bound(1, 179, "deg").arg(), default=70.0)
    st.add_argument("--distortion", type=Bound(-10, 10).arg(), nargs=5, default=(0, 0, 0, 0, 0),
                    metavar=("K1", "K2", "P1", "P2", "K3"))
    st.add_argument("--altitude", type=HEIGHT_M.arg(), help="raster height above the site datum, m")
    st.add_argument("--orbit-images", type=Bound(3, 10_000, integer=True).arg())
    st.add_argument("--sun", type=Bound(-360, 360, "deg").arg(), nargs=2, default=(135.0, 40.0),
                    metavar=("AZIMUTH_DEG", "ELEVATION_DEG"))
    st.add_argument("--noise-sigma", type=Bound(0, 255).arg(), default=1.5, help="sensor noise, DN")
    st.add_argument("--vignetting", type=Bound(0, 1).arg(), default=0.15)
    st.add_argument("--gps-sigma", type=Bound(0, 1_000, "m").arg(), nargs=2, default=(1.0, 2.0),
                    metavar=("HORIZONTAL_M", "VERTICAL_M"))
    st.add_argument("--threads", type=THREADS.arg(), help="render threads (default: all cores)")
    st.add_argument("--figures", action="store_true",
                    help="also write contact_sheet.png and scene_3d.png into --out")
    st.add_argument("--jpeg", action="store_true",
                    help="JPEGs with EXIF (GPS, altitude, time, focal length) instead of PNGs")
    st.add_argument("--start-time", default="2026-06-01T09:00:00",
                    help="--jpeg: the first image's capture time (camera local time)")
    st.add_argument("--exif-style", choices=("sim", "dji"), default="sim",
                    help="--jpeg: the simulator's EXIF, or a DJI Phantom 3's (make DJI, model "
                    "FC300S, no focal plane resolution, the drone-dji XMP packet)")
    st.add_argument("--gps-latency", type=Bound(-5, 5, "s").arg(), default=0.0,
                    help="--jpeg: the EXIF position is where the camera was this long before "
                    "the shutter (DJI's GNSS latency; one photo every 2 s; default 0)")
    st.set_defaults(func=cmd_sim_site)
    sfl = simp.add_parser("flight", help="a planned survey's photos as one card folder "
                          "(DCIM/100MEDIA/DJI_NNNN.JPG with EXIF; transit frames included)")
    sfl.add_argument("plan", help="plan.json (mound_plan; every flight, in order)")
    sfl.add_argument("--sites", help="its sites document with the hidden truth (default: "
                     "sites.json beside the plan)")
    sfl.add_argument("--out", required=True, help="the card's folder")
    sfl.add_argument("--truth", help="also write what each file is (mound.card_truth v1)")
    sfl.add_argument("--start-time", default="2026-06-01T09:00:00",
                     help="take-off of the first flight (camera local time)")
    sfl.add_argument("--speed", type=SPEED_M_S.arg(), default=10.0, help="ground speed, m/s")
    sfl.add_argument("--transit-every-s", type=Bound(0, 3_600, "s").arg(), default=10.0,
                     help="a transit frame every this many seconds between sites (0: none)")
    sfl.add_argument("--sim-seed", type=SIM_SEED.arg(),
                     default=1, help="as the survey's --sim-seed")
    sfl.add_argument("--image-size", type=IMAGE_PX.arg(), nargs=2, default=(640, 480),
                     metavar=("W", "H"))
    sfl.add_argument("--scan-pattern", choices=("raster", "orbit", "both"), default="raster")
    sfl.add_argument("--site-diameter", dest="site_diameter_m", metavar="D",
                     type=SITE_DIAMETER_M.arg(),
                     default=DEFAULT_SITE_DIAMETER_M,
                     help="as the survey's --site-diameter, m")
    sfl.add_argument("--threads", type=THREADS.arg(), help="render threads (default: all cores)")
    sfl.add_argument("--scan-factor", type=Bound(1, 100).arg(), default=1.0,
                     help="each site flown with a scan this many times as wide: the card of "
                     "a survey's second looks (PLAN: its second_look/plan.json, --sites its "
                     "sites.json, the factor its second_look/mission.json's scan_factor)")
    sfl.set_defaults(func=cmd_sim_flight)
    sf = simp.add_parser("figures", help="contact sheet and 3-D plot of a simulated site")
    sf.add_argument("site")
    sf.add_argument("--out-dir", help="default: the site directory")
    sf.add_argument("--dpi-scale", type=Bound(0.05, 10).arg(),
                    default=1.0, help="smaller files below 1")
    sf.set_defaults(func=cmd_sim_figures)

    return simp
