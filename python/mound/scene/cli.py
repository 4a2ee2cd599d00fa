"""`mound scene train | score | eval`: the coarse search on satellite scenes (GeoTIFF).

    mound scene train SCENE.tif [...] --labels KNOWN.geojson --out MODEL.json
          [--bands B,...] [--band-names N,...] [--features multiscale|paper]
          [--resample-m M] [--basis hinge|none] [--negative-distance-m 40]
          [--negatives-per-scene 1500] [--folds 5] [--l2 X] [--solver gd|lbfgs] [--seed 0]
    mound scene score SCENE.tif --model MODEL.json --out DIR [--stride-m S]
          [--candidates N] [--min-separation-m D] [--aoi AOI.geojson] [--home LAT,LON]
          [--band-names N,...] [--threads T] [--block CELLS] [--scheduler ADDRESS]
    mound scene eval SCENE.tif [...] --labels KNOWN.geojson [--band-names N,...]
          [--figure PNG] [--json OUT.json] [--paper-resample-m M]
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from mound.args import command_group, parse_lat_lon, parse_names
from mound.bounds import CANDIDATES, SEED, THREADS, Bound
from mound.errors import InputError
from mound.scene import workflow


def cmd_train(args: argparse.Namespace) -> int:
    model = workflow.train_model(
        args.scenes, args.labels, args.out, bands=parse_names(args.bands),
        band_names=parse_names(args.band_names), features=args.features,
        resample_m=args.resample_m, basis=args.basis,
        negative_distance_m=args.negative_distance_m,
        negatives_per_scene=args.negatives_per_scene, folds=args.folds,
        l2=args.l2, solver=args.solver, seed=args.seed, threads=args.threads)
    cv = model.info.get("cross_validation")
    f = model.info["fit"]
    print(f"{model.spec.kind} features ({len(model.spec.names())}), basis {model.basis}, "
          f"l2 {f['l2']:g}, {f['solver']} {f['iterations']} iterations "
          f"({'converged' if f['converged'] else 'not converged'}) -> {args.out}")
    if cv:
        print(f"leave-scenes-out: AUC {cv['auc_mean']:.3f} (median {cv['auc_median']:.3f}), "
              f"AP {cv['ap_mean']:.3f}, recall@5 {cv['recall_at_5']:.3f} of {cv['mounds']} "
              f"mounds in {cv['scenes']} scenes; threshold {model.threshold:.3f}")
    return 0


def cmd_score(args: argparse.Namespace) -> int:
    from mound.datasets import sha256_of
    from mound.jsonio import read_json
    from mound.scene import score
    from mound.scene.model import SCHEMA, VERSION, SceneModel
    from mound.scene.raster import open_scene
    from mound.scene.vector import read_aoi

    model = SceneModel.from_doc(read_json(args.model, SCHEMA, VERSION), args.model)
    scene = open_scene(args.scene, parse_names(args.band_names))
    score.keep_freed_blocks()
    aoi = (score.aoi_in_scene(read_aoi(args.aoi), scene, f"--aoi {args.aoi}")
           if args.aoi else None)
    if args.threads < 1:
        raise InputError("--threads: must be >= 1")

    def progress(done: int, total: int) -> None:
        if done == total or done % max(1, total // 10) == 0:
            workflow.say(f"{done}/{total} blocks")

    doc = score.score_to_dir(scene, model, args.out, model_path=args.model,
                             model_sha256=sha256_of(Path(args.model)), stride_m=args.stride_m,
                             limit=args.candidates, min_sep_m=args.min_separation_m, aoi=aoi,
                             aoi_path=args.aoi, home=parse_lat_lon(args.home), block=args.block,
                             threads=args.threads, scheduler=args.scheduler,
                             progress=progress, engine=args.engine)
    t = doc["timings"]
    print(f"{doc['counts']['scored']} of {doc['counts']['cells']} cells scored, "
          f"{doc['counts']['candidates']} candidates, {t['wall_s']:.2f} s "
          f"({t['mpx_per_s']:.2f} Mpx/s) -> {args.out}/")
    return 0


def cmd_eval(args: argparse.Namespace) -> int:
    from mound.scene import evaluate

    doc = evaluate.run(args.scenes, args.labels, band_names=parse_names(args.band_names),
                       bands=parse_names(args.bands), folds=args.folds, seed=args.seed,
                       paper_resample_m=args.paper_resample_m, figure=args.figure,
                       json_out=args.json, threads=args.threads, progress=workflow.say)
    print(evaluate.format_table(doc))
    return 0


FOLDS = Bound(2, 100, integer=True)
RESAMPLE_M = Bound(0, 1_000, "m", above=True)


def add_parser(sub: Any, parser_class: Any) -> None:
    sc = command_group(sub, "scene", "coarse search on satellite scenes (GeoTIFF)", parser_class)
    threads = min(2, os.cpu_count() or 1)

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument("--band-names", help="names of all the file's bands in order, e.g. "
                       "blue,green,red,nir (default: the file's band descriptions)")
        p.add_argument("--threads", type=THREADS.arg(), default=threads, help="scoring threads")

    t = sc.add_parser("train", help="learn p(mound) from scenes and known mounds")
    t.add_argument("scenes", nargs="+", help="GeoTIFF scenes (one or more)")
    t.add_argument("--labels", required=True, help="GeoJSON points (WGS84), properties.kind "
                   "mound | not_mound")
    t.add_argument("--out", required=True, help="model JSON")
    t.add_argument("--bands", help="bands by 1-based index or name, e.g. red,nir "
                   "(default: all)")
    t.add_argument("--features", choices=("multiscale", "paper"), default="multiscale")
    t.add_argument("--resample-m", type=RESAMPLE_M.arg(), default=8.0,
                   help="paper features: the ground resolution of the 3 x 3 pixels, m")
    t.add_argument("--basis", choices=("hinge", "none"), default="hinge",
                   help="multiscale: per-feature piecewise-linear basis (hinge) or linear")
    t.add_argument("--negative-distance-m", type=Bound(0, 10_000, "m", above=True).arg(),
                   default=40.0)
    t.add_argument("--negatives-per-scene", type=Bound(10, 1_000_000, integer=True).arg(),
                   default=1500)
    t.add_argument("--folds", type=FOLDS.arg(), default=5, help="cross-validation folds of scenes")
    t.add_argument("--l2", type=Bound(0, 1e6).arg(),
                   help="fix the regularisation (default: chosen by "
                   "cross-validation over scenes)")
    t.add_argument("--solver", choices=("gd", "lbfgs"), default="gd",
                   help="final fit: the paper's gradient descent, or L-BFGS (same objective)")
    t.add_argument("--seed", type=SEED.arg(), default=0)
    common(t)
    t.set_defaults(func=cmd_train)

    s = sc.add_parser("score", help="p(mound), reward and candidate sites of a scene")
    s.add_argument("scene")
    s.add_argument("--model", required=True)
    s.add_argument("--out", required=True, help="output folder")
    s.add_argument("--stride-m", type=Bound(0, 1_000, "m", above=True).arg(),
                   help="score every S metres (default: every pixel)")
    s.add_argument("--candidates", type=CANDIDATES.arg(),
                   default=20, help="how many candidate sites")
    s.add_argument("--min-separation-m", type=Bound(0, 10_000, "m").arg(), default=30.0,
                   help="candidates are local maxima of p at least this far apart, m")
    s.add_argument("--aoi", help="GeoJSON polygon(s), WGS84: score only inside")
    s.add_argument("--home", help="LAT,LON: add the take-off point as a 'home' feature")
    s.add_argument("--block", type=Bound(16, 8192, integer=True).arg(),
                   help="block side, output cells (default: 1024 scene pixels' worth)")
    s.add_argument("--scheduler", help="Dask scheduler address (default: local threads)")
    s.add_argument("--engine", choices=("native", "numpy"), default="native",
                   help="multiscale features: the compiled kernel (mound_scene) or the numpy "
                   "reference it is tested against")
    common(s)
    s.set_defaults(func=cmd_score)

    e = sc.add_parser("eval", help="leave-scenes-out evaluation: paper vs multiscale vs "
                      "chance")
    e.add_argument("scenes", nargs="+")
    e.add_argument("--labels", required=True)
    e.add_argument("--bands", help="bands by index or name (default: all)")
    e.add_argument("--folds", type=FOLDS.arg(), default=5)
    e.add_argument("--seed", type=SEED.arg(), default=0)
    e.add_argument("--paper-resample-m", type=RESAMPLE_M.arg(), default=8.0,
                   help="the paper's 3 x 3 pixels at this ground resolution, m")
    e.add_argument("--figure", help="PNG: p over a few held-out scenes, known mounds marked")
    e.add_argument("--json", help="all figures as JSON")
    common(e)
    e.set_defaults(func=cmd_eval)
