"""`mound recon`: the 3-D stage's Python side (figures, rasters); the verdict's learning
adds its commands to the group (mound.training.cli)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mound.args import Commands, command_group
from mound.bounds import (
    Bound,
)


def cmd_recon_figure(args: argparse.Namespace) -> int:
    from mound.recon import figures as recon_figures

    out = recon_figures.cloud_and_cameras(args.recon_dir, args.out)
    print(f"-> {out}")
    return 0


def cmd_recon_rasters(args: argparse.Namespace) -> int:
    from mound.recon import rasters
    from mound.recon.defaults import DENSE_CELL_M, SPARSE_CELL_M

    cell = args.resolution_m or (DENSE_CELL_M if args.cloud else SPARSE_CELL_M)
    doc = rasters.from_recon(Path(args.recon_dir), Path(args.out), cell,
                             Path(args.cloud) if args.cloud else None,
                             args.ground_window_m, args.relief_sigma_m,
                             ortho=not args.no_orthophoto,
                             images_dir=Path(args.images) if args.images else None)
    print(f"{doc['crs']}, {doc['width']} x {doc['height']} cells of {doc['resolution_m']:g} m, "
          f"{100 * doc['coverage']:.1f} % covered -> {args.out}/"
          f"{{{','.join(doc['files'])}}}.tif, rasters.json")
    return 0


def add_parser(sub: Any, parser_class: Any) -> Commands[argparse.ArgumentParser]:
    """The `recon` command group (returned: mound.training.cli adds to it)."""
    rc = command_group(sub, "recon", "the 3-D stage (Python side)", parser_class)
    rf = rc.add_parser("figure", help="picture of a mound_recon output: cloud + cameras")
    rf.add_argument("recon_dir")
    rf.add_argument("--out", required=True, help="PNG file")
    rf.set_defaults(func=cmd_recon_figure)
    rr = rc.add_parser("rasters", help="DSM, DTM, local relief model, hillshade and "
                       "orthophoto GeoTIFFs (UTM) of a metric mound_recon model")
    rr.add_argument("recon_dir")
    rr.add_argument("--out", required=True, help="output folder")
    rr.add_argument("--resolution-m", type=Bound(0.01, 100, "m").arg(),
                    help="cell size, m (default: the survey's, 0.5 with a dense --cloud, 2 "
                    "for the sparse points)")
    rr.add_argument("--cloud", help="a PLY cloud in the model's frame instead of points.ply")
    rr.add_argument("--ground-window-m", type=Bound(0, 10_000, "m", above=True).arg(), default=80.0,
                    help="largest window of the ground filter (> the mounds' diameter), m")
    rr.add_argument("--relief-sigma-m", type=Bound(0, 10_000, "m", above=True).arg(), default=30.0,
                    help="Gaussian smoothing of the terrain for the relief model, m")
    rr.add_argument("--images", help="the model's images (default: recon.json's images_dir)")
    rr.add_argument("--no-orthophoto", action="store_true", help="skip orthophoto.tif")
    rr.set_defaults(func=cmd_recon_rasters)
    return rc
