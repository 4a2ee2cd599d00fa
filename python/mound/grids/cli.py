"""`mound sim grid`: the verdict's grids of simulated sites, flown, reconstructed and judged."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from mound import datasets
from mound.bounds import (
    GRID_SEED,
    IMAGE_PX,
    THREADS,
    WORKERS,
    Bound,
)
from mound.errors import EXIT_NO_RESULT, InputError
from mound.formats.grid import GridRow
from mound.recon.defaults import CANDIDATES


def cmd_sim_grid(args: argparse.Namespace) -> int:
    from mound.grids import run as grid
    from mound.paths import shared_data_dir

    if args.workers < 1 or args.threads < 1:
        raise InputError("--workers, --threads: must be >= 1")

    def progress(k: int, row: GridRow) -> None:
        print(f"{row.dir}: {row.truth['kind']!s:<9} {row.look.status} "
              f"({sum(row.look.times_s.values()):.1f} s)", flush=True)

    dem: list[str] | None = None
    if args.dem == ["none"]:
        dem = None
    elif args.dem and "none" in args.dem:
        raise InputError("--dem: none cannot be given with a DEM")
    elif args.dem:
        dem = args.dem
    else:
        # A quarter of the draws are terrain patches of the DEM: without it the same seed
        # would draw another grid, so a missing default is an error, not a quiet change.
        here = [p / "dem" / grid.DEFAULT_DEM for p in (datasets.cache_dir(), shared_data_dir())]
        found = [p for p in here if p.is_file()]
        if not found:
            raise InputError(f"--dem: no DEM at {here[0]} nor {here[1]}: pass --dem FILE "
                             f"(the 1 m laser DEM, {grid.DEFAULT_DEM}), or --dem none to "
                             "draw the grid without terrain patches (another grid)")
        dem = [str(found[0])]
    doc = grid.make_grid(args.out, args.sites, args.seed, tuple(args.size), dem,
                         args.threads, args.workers, args.remeasure, progress,
                         pattern=args.pattern, dense=args.dense, card=args.card,
                         flights_from=args.flights_from, second_look=args.second_look,
                         dem_part=args.dem_part, population=args.population,
                         second_look_kind=args.second_look_kind, ground=args.ground,
                         candidates=args.candidates)
    print(f"{doc['measured']} of {doc['sites']} sites measured in {doc['wall_s']:.0f} s -> "
          f"{args.out}/grid.json")
    if "earlier_tools" in doc:
        print(f"note: {args.out}: verdicts made before were made by another build of "
              "mound_recon (grid.json: earlier_tools); --remeasure judges every site with "
              "this one", file=sys.stderr)
    if doc["status"] == "failed":
        reasons = sorted({str(r.get("reason", "?"))[:120] for r in doc["rows"]})
        print(f"mound sim grid: no result: no site was measured ({reasons[0]}"
              f"{f' and {len(reasons) - 1} other reasons' if len(reasons) > 1 else ''}; "
              f"each site's log.txt says more)", file=sys.stderr)
        return EXIT_NO_RESULT
    return 0


def add_parser(simp: Any, parser_class: Any) -> None:
    """`grid` in the `sim` command group (its subparsers `simp`)."""
    sg = simp.add_parser("grid", help="sites that look like the field (tumuli of every shape, "
                         "confusers), flown, reconstructed and measured: the verdict's data")
    sg.add_argument("--out", required=True, help="the grid's folder (resumable)")
    sg.add_argument("--sites", type=Bound(1, 99_999, integer=True).arg(), default=200)
    sg.add_argument("--seed", type=GRID_SEED.arg(), default=1, help="another seed: another grid")
    sg.add_argument("--size", type=IMAGE_PX.arg(), nargs=2, default=(320, 240), metavar=("W", "H"),
                    help="image size (small: the grid runs in minutes)")
    sg.add_argument("--dem", action="append", help="a DEM for real terrain patches, in a "
                    "CRS in metres; repeat it for several (each patch on one drawn among "
                    "those it fits on; default: the 1 m laser DEM in $MOUND_DATA/dem or "
                    "../shared/data/dem, an error when neither holds it); none: no terrain "
                    "patches (other draws)")
    sg.add_argument("--dem-part", choices=("all", "train", "heldout"), default="all",
                    help="where on each DEM the patches lie: train, the first 60 %% across "
                    "its longer axis (west or north); heldout, the rest; all (default)")
    sg.add_argument("--population", metavar="kazanlak|FILE",
                    help="draw each tumulus's base length, width, height and looters' trench "
                    "from a measured inventory (GeoJSON with length_m, width_m, height_m, "
                    "robber_trench; kazanlak: the Kazanlak inventory) instead of the uniform "
                    "ranges")
    sg.add_argument("--ground", choices=("mixed", "steep", "ridged"), default="mixed",
                    help="mixed: undulating, 2-15 degree slopes and DEM patches (default); "
                    "steep: every site on a 15-35 degree slope, over a DEM patch or "
                    "undulating ground; ridged: ridge-and-valley ground, terraced on half "
                    "the sites (no DEM)")
    sg.add_argument("--workers", type=WORKERS.arg(), default=2, help="sites at once")
    sg.add_argument("--threads", type=THREADS.arg(), default=1, help="threads per site")
    sg.add_argument("--pattern", choices=("raster", "both"), default="raster",
                    help="raster: the survey's scan (default); both: the full 40-image "
                    "flight (the raster and an oblique orbit)")
    sg.add_argument("--dense", action="store_true",
                    help="densify each site (mound_recon densify) and judge the dense cloud")
    sg.add_argument("--card", action="store_true",
                    help="reconstruct each site as from the aircraft's photo card (JPEGs "
                    "with EXIF, the lens refined about EXIF's values) instead of the simulator's "
                    "calibration")
    sg.add_argument("--flights-from", metavar="GRID",
                    help="take each site's flight and reconstruction from this grid (the same "
                    "--seed, --size, --pattern and --card): e.g. --dense on a sparse grid's "
                    "sites without flying them again")
    sg.add_argument("--candidates", choices=CANDIDATES, default="site_ground",
                    help="the candidate rises each verdict measures (mound_recon verdict "
                    "--candidates): site_ground, as the built-in models were trained "
                    "(default); local_relief, those and the local relief's blobs at every "
                    "scale (a model trained on the grid then names it). A site measured "
                    "with another set is measured again")
    sg.add_argument("--remeasure", action="store_true",
                    help="rerun only the verdicts (after a change of the detector)")
    sg.add_argument("--second-look", action="store_true",
                    help="fly each site the first verdict leaves undecided again with a scan "
                    "twice as wide (NNNN/second/): what train-verdict learns the second "
                    "look's calibration from")
    sg.add_argument("--second-look-kind", choices=("wider", "lower"), default="wider",
                    help="with --second-look: wider (the scan twice as wide, NNNN/second/) or "
                    "lower (the same scan with the raster half as high: the ground sampled "
                    "twice as finely, NNNN/second_lower/)")
    sg.set_defaults(func=cmd_sim_grid)
