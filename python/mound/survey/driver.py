"""`python python/mission.py`: the whole survey, from satellite data to a verdict per site.

Stages, each writing into the run directory (tree.py) and skipped on a rerun when its
inputs and options are unchanged (ledger.py):

    classify   train the coarse-search classifier on Statlog sat.trn, evaluate on sat.tst
    field      the candidate sites: the paper's 10 x 10 protocol (field seed, flyable
               spacing) or the user's --sites file; p(mound), reward, scan costs
    plan       mound_plan: the orienteering tour within the budget
    mission    the tour as a MAVLink mission (.plan, .waypoints, .geojson), uploaded and
               read back with --connect
    photos     with --photos CARD: the aircraft's card sorted into the visited sites
               (mound photos sort: photos.json, photos/<site id>/); with --second-photos
               the card of the second looks too (photos_second/)
    sites3d    per visited site on Dask: its flight simulated from the site's hidden truth
               (or the photos of --photos / --images-root), mound_recon reconstruct,
               mound_recon verdict, the site's pictures; a failing site is reported and the
               rest go on. With --learn, flight by flight: after each, the verdicts
               retrain the classifier and the next flight is re-planned (learn.py).
               A site the verdict leaves undecided is flown again wider (simulated, or
               from --second-photos); the missions of those second looks are written to
               second_look/
    report     final labels (the 3-D verdict where visited, the classifier's elsewhere),
               eps_MD / eps_FA, summary.json (mound.survey v1), report.html, report.md
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import shutil
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, get_args

import numpy as np

from mound import native
from mound.args import Parser
from mound.datasets import sha256_of
from mound.errors import EXIT_NO_RESULT, InputError, exit_for
from mound.jsonio import read_json, write_all_atomic, write_json
from mound.survey.ledger import Ledger, StageRecord, digest
from mound.survey.options import (
    NUMBERS,
    Algo,
    DjiAircraft,
    Firmware,
    ScanPattern,
    SurveyOptions,
)
from mound.survey.tree import RunTree

STAGES = ("classify", "field", "plan", "mission", "photos", "sites3d", "report")
assert len(STAGES) == 7  # Context.redo_from: past the last stage
SCHEMA = "mound.survey"
VERSION = 1


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows defaults, except None and False (options that are off unless given)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.default in (None, False, argparse.SUPPRESS):
            return action.help or ""
        return super()._get_help_string(action) or ""


def build_parser() -> argparse.ArgumentParser:
    D = SurveyOptions()  # the defaults, in one place
    p = Parser(
        prog="python python/mission.py",
        description="The whole survey in one command: classifier -> candidate sites -> "
        "tour (mound_plan) -> MAVLink mission -> per visited site its flight (simulated, "
        "or your photos), mound_recon reconstruct and verdict -> final labels, eps_MD, "
        "eps_FA, summary.json and report.html. A rerun with the same options skips what "
        "is done (interrupt it any time and run it again).",
        formatter_class=HelpFormatter)
    p.add_argument("--out", default=D.out, help="run directory")
    g = p.add_argument_group("candidate sites")
    g.add_argument("--field-seed", type=NUMBERS["field_seed"].arg(), default=D.field_seed,
                   help="the paper's protocol: a 10 x 10 field of Statlog sat.tst examples, "
                   "3-5 of them positives (mounds); seeds 0-9 are the standard fields")
    g.add_argument("--spacing", type=NUMBERS["spacing"].arg(), default=D.spacing,
                   help="distance between neighbouring sites of the field, m")
    g.add_argument("--sites", help="your own sites instead: a mound.sites JSON or a GeoJSON "
                   "FeatureCollection of points (a 'home' feature, then sites with p_mound, "
                   "optional reward and truth); see docs/survey.md")
    g.add_argument("--budget", type=NUMBERS["budget"].arg(),
                   help="flight distance budget, m (default: the "
                   "sites file's budget_m, else the aircraft's range, 14,400 m)")
    g = p.add_argument_group("satellite scene (instead of the field or --sites)")
    g.add_argument("--scene", nargs="+", help="GeoTIFF scene(s): the candidate sites are the "
                   "local maxima of p(mound) (mound scene score)")
    g.add_argument("--labels", help="known mounds (GeoJSON points, WGS84): the scene model is "
                   "learned from them, and they give the truth of the candidates near them")
    g.add_argument("--scene-model", help="a model of mound scene train instead of --labels")
    g.add_argument("--home", help="LAT,LON of the take-off point (needed with --scene; "
                   "with the field: where the field's home is, default Bin Tepe)")
    g.add_argument("--aoi", help="GeoJSON polygon(s): candidates only inside")
    g.add_argument("--band-names", help="names of the scene's bands, e.g. blue,green,red,nir")
    g.add_argument("--candidates", type=NUMBERS["candidates"].arg(), default=D.candidates,
                   help="candidate sites from the scene")
    g.add_argument("--min-separation-m", type=NUMBERS["min_separation_m"].arg(),
                   default=D.min_separation_m,
                   help="candidates at least this far apart, m")
    g = p.add_argument_group("flight")
    g.add_argument("--scan-pattern", choices=get_args(ScanPattern), default=D.scan_pattern,
                   help="how each site is scanned (the mission flies it, the simulator "
                   "renders it, the planner pays for it)")
    g.add_argument("--site-diameter", type=NUMBERS["site_diameter"].arg(), default=D.site_diameter,
                   help="size of the scan (and of a simulated tumulus), m")
    g.add_argument("--algo", default=D.algo, choices=get_args(Algo),
                   help="mound_plan's algorithm (default alns: ALNS-OP, 1 s at most; newalg: "
                   "the paper's)")
    g.add_argument("--plan-seed", type=NUMBERS["plan_seed"].arg(),
                   default=D.plan_seed, help="mound_plan's seed")
    g.add_argument("--flights", type=NUMBERS["flights"].arg(), default=D.flights,
                   help="flights (batteries or aircraft) from home, each within the budget; "
                   "one mission each (mission_1.plan, ... ordered by reward)")
    from mound.uav.terrain import add_arguments as add_terrain_arguments

    add_terrain_arguments(p)
    g.add_argument("--connect", help="also upload the mission to this MAVLink vehicle and "
                   "read it back (udpout:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT, serial)")
    g.add_argument("--firmware", choices=get_args(Firmware), default=D.firmware,
                   help="the vehicle's dialect of mission items (default: px4)")
    g.add_argument("--aircraft", choices=get_args(DjiAircraft), default=D.aircraft,
                   help="the DJI aircraft of each flight's mission.kmz (WPML for DJI Pilot 2; "
                   "mini4pro and air3 fly the Litchi mission.csv); every flight is also "
                   "written as .plan, .waypoints and .csv")
    g = p.add_argument_group("3-D stage")
    g.add_argument("--photos", metavar="CARD_DIR", help="the aircraft's photo card (or a copy "
                   "of it): sorted into the visited sites by EXIF GPS and time (mound photos "
                   "sort), each site's folder reconstructed; default: simulate each visited "
                   "site's flight from its hidden truth")
    g.add_argument("--second-photos", metavar="CARD_DIR", help="with --photos: the card of "
                   "the second looks the first verdicts advised (second_look/mission.plan of "
                   "the run before), sorted by second_look/plan.json; each such site is then "
                   "decided by both flights")
    g.add_argument("--camera", help="with --photos: the camera (mound.camera v1) instead of "
                   "the photos' EXIF")
    g.add_argument("--images-root", help="the UAV's photos sorted by hand: one folder per "
                   "site id (with camera.json / poses.json when known, else EXIF)")
    g.add_argument("--learn", action="store_true",
                   help="with --flights K on the field: after each flight, the verdicts "
                   "(weighted by their confidence) retrain the coarse classifier, p_mound "
                   "and rewards are recomputed and the next flight is re-planned over the "
                   "sites not yet flown")
    g.add_argument("--learn-weight", type=NUMBERS["learn_weight"].arg(), default=D.learn_weight,
                   help="--learn: training examples a verified site counts as (times the "
                   "verdict's confidence)")
    g.add_argument("--image-size", type=NUMBERS["image_size"].arg(), nargs=2, default=D.image_size,
                   metavar=("W", "H"), help="simulated image size, px")
    g.add_argument("--sim-seed", type=NUMBERS["sim_seed"].arg(),
                   default=D.sim_seed, help="seed of the simulated sites")
    g.add_argument("--max-features", type=NUMBERS["max_features"].arg(), default=D.max_features,
                   help="SIFT features per image (mound_recon reconstruct)")
    g.add_argument("--dense-size", type=NUMBERS["dense_size"].arg(),
                   default=D.dense_size, metavar="PX",
                   help="depth maps of mound_recon densify, longer side px (0: no dense "
                   "cloud; the site's GeoTIFFs then come from the sparse one)")
    g.add_argument("--reference", help="judge by the paper's test against this reference "
                   "mound (PLY) instead of the reference-free dome detector")
    g.add_argument("--verdict-model", metavar="FILE",
                   help="the dense cloud's verdict model (mound.verdict_model v1) in place of "
                   "the built-in one, e.g. one remade by `mound recon train-verdict`; one "
                   "with a second_look asks for second looks")
    g.add_argument("--site-timeout", type=NUMBERS["site_timeout"].arg(), default=D.site_timeout,
                   help="limit per tool run of a site, s")
    g = p.add_argument_group("scale-out")
    g.add_argument("--scheduler", help="address of a running Dask scheduler "
                   "(tcp://HOST:8786); default: a local cluster")
    g.add_argument("--workers", type=NUMBERS["workers"].arg(),
                   help="local cluster: worker processes "
                   "(default: one per core)")
    g.add_argument("--site-threads", type=NUMBERS["site_threads"].arg(), default=D.site_threads,
                   help="threads of each site's tools (one task per worker thread)")
    g = p.add_argument_group("report")
    g.add_argument("--basemap", metavar="URL", help="map.html: tiles from your own tile server "
                   "under the overlays (https://HOST/{z}/{x}/{y}.png); default: none, the "
                   "page works offline")
    g = p.add_argument_group("run")
    g.add_argument("--force", action="store_true", help="redo every stage")
    g.add_argument("--rerun-from", choices=STAGES,
                   help="redo this stage and those after it")
    g.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


@dataclass
class Context:
    args: SurveyOptions
    tree: RunTree
    ledger: Ledger
    stages: list[dict[str, Any]] = field(default_factory=list)
    keys: dict[str, str] = field(default_factory=dict)
    redo_from: int = 7  # index into STAGES (len: none): stages from here on are redone
    run_id: str = field(default_factory=lambda: uuid.uuid4().hex)

    @functools.cached_property
    def terrain(self) -> dict[str, Any] | None:
        """What the terrain makes of a stage (the DEM's bytes, hashed once per run, and every
        terrain option); None without --dem."""
        return terrain_material(self.args)

    def say(self, text: str) -> None:
        print(text, flush=True)


def run_stage(ctx: Context, name: str, material: dict[str, Any], work: Any) -> str:
    """Runs `work()` -> (outputs relative to the run directory, a one-line note) unless the
    ledger holds this stage with the same key and its outputs; records it."""
    key = digest({"stage": name, **material})
    ctx.keys[name] = key
    redo = STAGES.index(name) >= ctx.redo_from
    if not redo and ctx.ledger.is_done(name, key):
        prev = ctx.ledger.previous(name)
        ctx.stages.append({"name": name, "wall_s": 0.0, "skipped": True,
                           "wall_s_when_run": prev.get("wall_s"), "note": prev.get("note", "")})
        ctx.say(f"[{name}] skipped, unchanged: {prev.get('note', '')} "
                f"(ran in {prev.get('wall_s', 0):.1f} s)")
        return key
    ctx.ledger.forget(name)
    start = time.perf_counter()
    outputs, note, complete = work()
    wall = time.perf_counter() - start
    if complete:
        ctx.ledger.record(StageRecord(name, key, wall, outputs, note=note))
    ctx.stages.append({"name": name, "wall_s": wall, "skipped": False, "note": note,
                       "complete": complete})
    ctx.say(f"[{name}] {note} ({wall:.1f} s)")
    return key


# ---------------------------------------------------------------------------- stages

def stage_classify(ctx: Context) -> str:
    from mound import datasets
    from mound.classify import coarse, statlog

    if ctx.args.scene:
        return stage_classify_scene(ctx)
    if ctx.args.sites:
        ctx.stages.append({"name": "classify", "wall_s": 0.0, "skipped": True,
                           "note": "not needed: --sites gives each site's p_mound"})
        ctx.say("[classify] not needed: --sites gives each site's p_mound")
        ctx.keys["classify"] = "user-sites"
        return "user-sites"

    def work() -> tuple[list[str], str, bool]:
        datasets.fetch(datasets.STATLOG)
        model = coarse.train(statlog.load("sat.trn"), coarse.DEFAULT_BAND)
        write_json(ctx.tree.model, model.to_doc())
        s = coarse.evaluate(model, statlog.load("sat.tst"))
        write_json(ctx.tree.classifier_eval, {
            "schema": "mound.classifier_eval", "version": 1,
            **{k: v for k, v in s.items() if k != "reliability"}})
        return (["model.json", "classifier.json"],
                f"band {model.band} logistic regression, sat.tst accuracy {s['accuracy']:.3f}, "
                f"AUC {s['auc']:.3f}", True)

    return run_stage(ctx, "classify", {"data": datasets.STATLOG.files,
                                       "band": coarse.DEFAULT_BAND, "l2": coarse.DEFAULT_L2},
                     work)


def _digest_files(paths: list[str]) -> list[str]:
    return [sha256_of(Path(p)) for p in paths]


def stage_classify_scene(ctx: Context) -> str:
    """The scene model: learned on the scene(s) from --labels, or the user's --scene-model."""
    from mound.args import parse_names
    from mound.jsonio import read_json as read_doc
    from mound.scene.model import SCHEMA as SCENE_SCHEMA
    from mound.scene.model import VERSION as SCENE_VERSION
    from mound.scene.model import SceneModel
    from mound.scene.workflow import train_model

    a = ctx.args
    path = ctx.tree.root / "scene_model.json"

    def work() -> tuple[list[str], str, bool]:
        if a.scene_model:
            doc = read_doc(a.scene_model, SCENE_SCHEMA, SCENE_VERSION)
            SceneModel.from_doc(doc, a.scene_model)
            write_json(path, doc)
            return ["scene_model.json"], f"scene model {a.scene_model}", True
        assert a.labels  # SurveyOptions.check: --labels or --scene-model
        model = train_model(a.scenes, a.labels, str(path), band_names=parse_names(a.band_names))
        cv = model.info.get("cross_validation") or {}
        note = (f"{model.spec.kind} scene model on {len(a.scenes)} scene(s)"
                + (f", leave-scenes-out AUC {cv['auc_mean']:.3f}, recall@5 "
                   f"{cv['recall_at_5']:.3f}" if cv.get("auc_mean") is not None else ""))
        return ["scene_model.json"], note, True

    material = {"scenes": _digest_files(a.scenes), "band_names": a.band_names,
                "labels": _digest_files([a.labels]) if a.labels else None,
                "model": _digest_files([a.scene_model]) if a.scene_model else None}
    return run_stage(ctx, "classify", material, work)


def scene_sites(ctx: Context, scan: Any) -> dict[str, Any]:
    """Scores each scene, merges their candidates (best first), gives each the truth of the
    labels within 15 m (a known mound, with its height_m; an explicit not_mound), and reads
    them as the run's sites; the others are simulated as flat ground, truth unknown."""
    from scipy.spatial import cKDTree

    from mound.args import parse_lat_lon, parse_names
    from mound.datasets import sha256_of as digest_of
    from mound.formats.sites import load_user_sites
    from mound.jsonio import read_json as read_doc
    from mound.scene import score
    from mound.scene.model import SCHEMA as SCENE_SCHEMA
    from mound.scene.model import VERSION as SCENE_VERSION
    from mound.scene.model import SceneModel
    from mound.scene.raster import open_scene, transformer_to_scene
    from mound.scene.train import FOUND_RADIUS_M
    from mound.scene.vector import read_aoi, read_labels
    from mound.uav.mission_items import flight_budget_m

    a = ctx.args
    model_path = ctx.tree.root / "scene_model.json"
    model = SceneModel.from_doc(read_doc(model_path, SCENE_SCHEMA, SCENE_VERSION),
                                str(model_path))
    home = parse_lat_lon(a.home)
    labels = read_labels(a.labels) if a.labels else []
    feats: list[dict[str, Any]] = []
    for k, scene_path in enumerate(a.scenes):
        scene = open_scene(scene_path, parse_names(a.band_names))
        aoi = None
        if a.aoi:
            try:
                aoi = score.aoi_in_scene(read_aoi(a.aoi), scene, f"--aoi {a.aoi}")
            except score.AoiMissesScene as e:
                if len(a.scenes) == 1:
                    raise
                ctx.say(f"[scene] {scene_path}: not scored: {e}")
                continue
        out = ctx.tree.root / "scene" / f"{k:02d}_{Path(scene_path).stem}"
        score.score_to_dir(scene, model, out, model_path=str(model_path),
                           model_sha256=digest_of(model_path), limit=a.candidates,
                           min_sep_m=a.min_separation_m, aoi=aoi, aoi_path=a.aoi)
        cands = json.loads((out / "candidates.geojson").read_text())["features"]
        if labels:
            tr = transformer_to_scene(scene)
            lx, ly = tr.transform([lb.lon for lb in labels], [lb.lat for lb in labels])
            tree = cKDTree(np.stack([lx, ly], 1))
        for c in cands:
            pr = c["properties"]
            pr["id"] = f"{Path(scene_path).stem}-{pr['id']}"
            pr["scene_dir"] = str(out.relative_to(ctx.tree.root))
            if labels:
                d, j = tree.query([pr["x"], pr["y"]])
                if d <= FOUND_RADIUS_M:
                    lb = labels[int(j)]
                    pr["truth"] = {"mound": lb.mound}
                    if lb.mound and isinstance(lb.props.get("height_m"), int | float):
                        pr["truth"]["height_m"] = float(lb.props["height_m"])
                    pr["label_id"] = lb.id
            feats.append(c)
    if not feats:
        raise InputError("--scene: no candidate site in the scene(s) (nodata or the AOI)")
    feats.sort(key=lambda f: (-f["properties"]["p_mound"], f["properties"]["id"]))
    # Overlapping scenes find the same place twice: keep the better of candidates closer
    # than the separation (local metres of an equirectangular projection at home).
    kept: list[dict[str, Any]] = []
    k_lat = 111_320.0
    k_lon = k_lat * np.cos(np.radians(home[0])) if home else k_lat
    for f in feats:
        lon, lat = f["geometry"]["coordinates"]
        if all(np.hypot((lon - g["geometry"]["coordinates"][0]) * k_lon,
                        (lat - g["geometry"]["coordinates"][1]) * k_lat) >= a.min_separation_m
               for g in kept):
            kept.append(f)
    feats = kept[:a.candidates]
    assert home is not None
    gj = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": [home[1], home[0]]},
         "properties": {"kind": "home"}}, *feats]}
    path = ctx.tree.root / "scene" / "candidates.geojson"
    write_json(path, gj)
    doc = load_user_sites(path, scan, a.budget, flight_budget_m(), need_truth=False)
    by_id = {f["properties"]["id"]: f["properties"] for f in feats}
    for s in doc["sites"]:
        pr = by_id[s["id"]]
        s["scene"] = {k: pr[k] for k in ("scene", "scene_dir", "x", "y", "rank")}
        if "truth" not in s:
            s["simulate"] = "flat"  # truth unknown: flown over flat ground, not counted
    doc["provenance"]["tool"] = "python/mission.py --scene"
    doc["provenance"]["scenes"] = a.scenes
    return doc


def scan_spec(args: SurveyOptions) -> Any:
    from mound.uav import mission_items

    scan = mission_items.scan_for_site(args.site_diameter, args.scan_pattern)
    from dataclasses import replace
    scan = replace(scan, width_px=args.image_size[0], height_px=args.image_size[1])
    scan.validate()
    return scan


def stage_field(ctx: Context) -> str:
    from mound.classify import statlog
    from mound.classify.model import SCHEMA as MODEL_SCHEMA
    from mound.classify.model import VERSION as MODEL_VERSION
    from mound.classify.model import Model
    from mound.formats.sites import load_user_sites
    from mound.plan.field import make_field, sites_document
    from mound.uav.mission_items import flight_budget_m

    a = ctx.args
    scan = scan_spec(a)
    if a.scene:
        material: dict[str, Any] = {
            "classify": ctx.keys["classify"], "scan": scan.to_doc(), "budget": a.budget,
            "labels": _digest_files([a.labels]) if a.labels else None, "home": a.home,
            "aoi": _digest_files([a.aoi]) if a.aoi else None, "n": a.candidates,
            "sep": a.min_separation_m}
    elif a.sites:
        # Validated now, before anything is planned or flown, even when the stage is
        # skipped: a bad file must stop the run here.
        doc = load_user_sites(a.sites, scan, a.budget, flight_budget_m(),
                              need_truth=not (a.images_root or a.photos))
        material = {"sites": doc}
    else:
        material = {"classify": ctx.keys["classify"], "seed": a.field_seed,
                    "spacing": a.spacing, "scan": scan.to_doc(), "budget": a.budget,
                    "home": a.home}
    material["terrain"] = ctx.terrain

    def work() -> tuple[list[str], str, bool]:
        if a.scene:
            out = scene_sites(ctx, scan)
        elif a.sites:
            out = doc
        else:
            test = statlog.load("sat.tst")
            model = Model.from_doc(read_json(ctx.tree.model, MODEL_SCHEMA, MODEL_VERSION),
                                   str(ctx.tree.model))
            out = sites_document(make_field(test, a.field_seed), test, model, None,
                                 a.budget if a.budget is not None else flight_budget_m(),
                                 spacing_m=a.spacing, scan=scan)
            if a.home:
                from mound.args import parse_lat_lon

                home = parse_lat_lon(a.home)
                assert home is not None  # a.home is set
                lat, lon = home
                out["origin"] = {"lat": lat, "lon": lon, "alt_m": 0.0}
        if a.dem:
            from mound.geometry.geodesy import Origin
            from mound.uav import terrain

            out = terrain.attach(out, a.dem, a.terrain_spec(), a.dem_vertical,
                                 Origin.from_doc(out["origin"], "sites: origin"))
        write_json(ctx.tree.sites, out)
        prov = out["provenance"]
        what = (f"field seed {a.field_seed}" if not (a.sites or a.scene) else
                f"{a.sites}" if a.sites else f"{len(a.scenes)} scene(s)")
        return (["sites.json"], f"{what}: {len(out['sites'])} sites, {prov['positives']} "
                f"true mounds, total reward {prov['total_reward']:.2f} bits, scan cost "
                f"{out['sites'][0]['scan_cost_m']:.0f} m per site"
                f"{' (energy, over the DEM)' if a.dem else ''}, budget "
                f"{out['budget_m']:.0f} m", True)

    return run_stage(ctx, "field", material, work)


def terrain_material(a: SurveyOptions) -> dict[str, Any] | None:
    """What the terrain makes of a stage (the DEM's bytes and every terrain option)."""
    if not a.dem:
        return None
    return {"dem": _digest_files([a.dem]), "vertical": a.dem_vertical,
            "clearance": a.clearance_m, "scan_clearance": a.scan_clearance_m,
            "footprint": a.footprint_m, "climb": a.climb_factor, "descent": a.descent_factor}


def stage_plan(ctx: Context) -> str:
    a = ctx.args

    def work() -> tuple[list[str], str, bool]:
        native.run_tool("mound_plan", [str(ctx.tree.sites), "--algo", a.algo, "--seed",
                                       str(a.plan_seed), "--flights", str(a.flights),
                                       "--out", str(ctx.tree.plan)],
                        timeout_s=600, log=ctx.tree.root / "log.txt")
        plan = read_json(ctx.tree.plan, "mound.plan", 1)
        if a.scene:
            from mound.survey import figures

            ctx.tree.report_dir.mkdir(parents=True, exist_ok=True)
            figures.scene_map(ctx.tree.root, read_json(ctx.tree.sites, "mound.sites", 1), plan,
                              ctx.tree.report_dir / "scene.png")
        each = "; ".join(f"flight {f['flight']}: {len(f['tour']) - 2} sites, "
                         f"{f['reward']:.2f} bits, {f['cost_m']:.0f} m"
                         for f in plan["flights"]) if len(plan["flights"]) > 1 else ""
        budget = (f"{plan['cost_m']:.0f} m in {len(plan['flights'])} flights of "
                  f"{plan['budget_m']:.0f} m each ({each})" if each else
                  f"{plan['cost_m']:.0f} m of {plan['budget_m']:.0f} m")
        return (["plan.json"], f"{a.algo}: {plan['n_visited']} of {plan['n_sites']} sites, "
                f"reward {plan['reward']:.2f} bits, {budget}", True)

    return run_stage(ctx, "plan", {"field": ctx.keys["field"], "algo": a.algo,
                                   "seed": a.plan_seed, "flights": a.flights}, work)


def mission_terrain(a: SurveyOptions) -> Any:
    """The DEM a mission is flown over (mission_items.TerrainInput), None without --dem."""
    if not a.dem:
        return None
    from mound.uav import mission_items
    return mission_items.TerrainInput(a.dem, a.dem_vertical, a.terrain_spec())


def write_missions(missions: list[tuple[int | None, Any]], folder: Path, png_folder: Path,
                   firmware: str, aircraft: str = "m3e") -> tuple[list[Path], dict[str, Any]]:
    """Each flight's mission (k None: the only one) in every format a crew flies:
    FOLDER/mission.plan, .waypoints (MAVLink), .kmz (DJI WPML for `aircraft`), .csv
    (Litchi; mission_partN.csv past 99 waypoints), .geojson (mission_K.* of several), and
    its map PNG_FOLDER/mission.png (mission_K.png); returns the files and the mound.mission
    summary: the only flight's own, or of several their totals, each under `flights`. A
    DJI or Litchi file a limit of theirs refuses is not written, and the summary's
    `formats` says why (the .plan is the reference and is always written)."""
    from mound.survey import figures
    from mound.uav import dji, litchi, mission_formats
    from mound.uav import files as mission_files

    written: list[Path] = []
    summaries = []
    for k, m in missions:
        files = {name: mission_files.flight_path(folder / name, k)
                 for name in ("mission.plan", "mission.waypoints", "mission.geojson")}
        mission_files.write_plan(files["mission.plan"], m, firmware)
        mission_files.write_wpl(files["mission.waypoints"], m)
        mission_files.write_geojson(files["mission.geojson"], m)
        formats: dict[str, Any] = {}
        try:
            craft = dji.aircraft(aircraft)
            kmz = mission_files.flight_path(folder / "mission.kmz", k)
            write_all_atomic([(kmz, mission_formats.kmz(m, craft))])
            files["mission.kmz"] = kmz
            formats["dji_kmz"] = {"file": kmz.name, "aircraft": craft.key,
                                  "heights": "relativeToStartPoint"}
        except InputError as e:
            formats["dji_kmz"] = {"file": None, "refused": str(e)}
        try:
            parts = mission_formats.litchi_parts(m)
            csv_path = mission_files.flight_path(folder / "mission.csv", k)
            paths = [litchi.part_path(csv_path, j + 1, len(parts)) for j in range(len(parts))]
            write_all_atomic(list(zip(paths, parts, strict=True)))
            files.update({p.name: p for p in paths})
            formats["litchi_csv"] = {"files": [p.name for p in paths]}
        except InputError as e:
            formats["litchi_csv"] = {"files": [], "refused": str(e)}
        png = mission_files.flight_path(png_folder / "mission.png", k)
        figures.mission_map(m.nav_enu, m.footprints, m.sites, png)
        written += [*files.values(), png]
        summaries.append({**m.summary(), "flight": k or 1, "file": files["mission.plan"].name,
                          "formats": formats})
    summary = dict(summaries[0]) if len(summaries) == 1 else {
        "schema": "mound.mission", "version": 1, "origin": summaries[0]["origin"],
        "items": sum(x["items"] for x in summaries),
        "flight_distance_m": sum(x["flight_distance_m"] for x in summaries),
        "budget_m": summaries[0]["budget_m"], "terrain": summaries[0]["terrain"]}
    summary["flights"] = summaries
    return written, summary


def stage_mission(ctx: Context) -> str:
    from mound.geometry.geodesy import Origin
    from mound.survey import figures
    from mound.uav import mission, mission_items
    from mound.uav.upload import upload_mission

    a = ctx.args
    t = ctx.tree

    def work() -> tuple[list[str], str, bool]:
        plan = read_json(t.plan, "mound.plan", 1)
        if not plan.get("n_visited"):
            return [], "nothing to fly: no site fits the budget", True
        origin = Origin.from_doc(plan["origin"], f"{t.plan}: origin")
        # The plan's scan, read once for every flight (build's own rule: else the default).
        scan = mission_items.plan_scan(plan, str(t.plan))
        spec = mission_items.MissionSpec(scan=scan) if scan else mission_items.MissionSpec()
        terrain = mission_terrain(a)
        flights = mission_items.flight_plans(plan)
        several = len(flights) > 1
        missions = [(f["flight"] if several else None,
                     mission.build(f, origin, spec, terrain)) for f in flights]
        t.report_dir.mkdir(parents=True, exist_ok=True)
        written, summary = write_missions(missions, t.root, t.report_dir, a.firmware,
                                          a.aircraft)
        made = [str(p.relative_to(t.root)) for p in written]
        notes = []
        for k, m in missions:
            tag = "" if k is None else f"_{k}"
            note = (f"{'' if k is None else f'flight {k}: '}{len(m.items)} MAVLink items, "
                    f"{len(m.sites)} sites, flight {m.flight_distance_m:.0f} m of "
                    f"{m.budget_m:.0f} m")
            if m.terrain is not None:
                figures.leg_profiles(m.terrain, t.report_dir / f"legs{tag}.png")
                made.append(f"report/legs{tag}.png")
                note += (f", over the DEM: energy {m.terrain['energy_m']:.0f} m, lowest "
                         f"transit clearance {m.terrain['lowest_clearance_m']:.1f} m")
            notes.append(note)
        for f in summary["flights"]:
            for fmt in f["formats"].values():
                if "refused" in fmt:
                    notes.append(f"flight {f['flight']}: {fmt['refused']} (not written)")
        note = "; ".join(notes)
        if missions[0][1].terrain is None:
            note += "; terrain not checked (no --dem)"
        if a.connect:
            first = t.flight_file("mission.plan", missions[0][0])
            r = upload_mission(first, a.connect, verify=True, firmware=a.firmware)
            summary["upload"] = {"connect": a.connect, "file": first.name, **r}
            note += (f"; {first.name} uploaded to system {r['target_system']} and read back "
                     f"({r['elapsed_s']:.2f} s)")
        else:
            note += "; not uploaded (no --connect)"
        write_json(t.mission_summary, summary)
        return ([*made, "mission.json"], note, True)

    return run_stage(ctx, "mission", {"plan": ctx.keys["plan"], "connect": a.connect,
                                      "firmware": a.firmware, "aircraft": a.aircraft,
                                      "terrain": ctx.terrain}, work)


def stage_photos(ctx: Context) -> str:
    """--photos: the card sorted into the visited sites of plan.json (links, photos.json)."""
    from mound.photos.sort import SortSpec, sort_card

    a = ctx.args
    if not a.photos:
        note = ("not needed: photos from --images-root" if a.images_root
                else "not needed: each visited site's flight is simulated")
        ctx.stages.append({"name": "photos", "wall_s": 0.0, "skipped": True, "note": note})
        ctx.say(f"[photos] {note}")
        ctx.keys["photos"] = "none"
        return "none"

    def work() -> tuple[list[str], str, bool]:
        assert a.photos
        doc = sort_card(a.photos, str(ctx.tree.plan), str(ctx.tree.photos),
                        SortSpec(site_diameter_m=a.site_diameter), a.camera)
        counts = ", ".join(f"{n} {k}" for k, n in sorted(doc["counts"].items()))
        ok = sum(1 for v in doc["sites"].values() if v["status"] == "ok")
        few = [k for k, v in doc["sites"].items() if v["status"] != "ok"]
        note = (f"{len(doc['photos'])} files on the card: {counts}; {ok} of "
                f"{len(doc['sites'])} visited sites with enough photos"
                + (f" (too few: {', '.join(few)})" if few else ""))
        made = ["photos/photos.json"]
        if a.second_photos:
            plan2 = ctx.tree.second_look / "plan.json"
            if not plan2.is_file():
                raise InputError(f"--second-photos: no second looks to sort it by ({plan2} "
                                 "is missing: the run before advised none, or has not run)")
            second = sort_card(a.second_photos, str(plan2), str(ctx.tree.second_photos),
                               SortSpec(site_diameter_m=a.site_diameter), a.camera)
            ok2 = [k for k, v in second["sites"].items() if v["status"] == "ok"]
            note += (f"; second card: {len(second['photos'])} files, {len(ok2)} of "
                     f"{len(second['sites'])} second looks with enough photos")
            made.append(str((ctx.tree.second_photos / "photos.json").relative_to(
                ctx.tree.root)))
        return made, note, True

    material = {"plan": ctx.keys["plan"], "card": _card_digest(Path(a.photos)),
                "camera": _digest_files([a.camera]) if a.camera else None,
                "diameter": a.site_diameter,
                "second_card": _card_digest(Path(a.second_photos)) if a.second_photos
                else None}
    return run_stage(ctx, "photos", material, work)


def _card_digest(card: Path) -> str:
    """The card's files (names, sizes, times): a changed card is sorted again."""
    rows = []
    for dirpath, _dirs, names in os.walk(card):
        for n in names:
            p = Path(dirpath) / n
            try:
                st = p.stat()
            except OSError:
                continue
            rows.append((str(p.relative_to(card)), st.st_size, st.st_mtime_ns))
    return digest(sorted(rows))


def _folder_digest(folder: Path) -> str:
    if not folder.is_dir():
        return "missing"
    return digest(sorted((p.name, p.stat().st_size, p.stat().st_mtime_ns)
                         for p in folder.iterdir() if p.is_file()))


def images_root(ctx: Context) -> Path | None:
    """Where each visited site's photos are: the sorted card (--photos), the user's
    folders (--images-root), or nowhere (simulated)."""
    if ctx.args.photos:
        return ctx.tree.photos
    return Path(ctx.args.images_root) if ctx.args.images_root else None


def site_jobs(ctx: Context, plan: dict[str, Any] | None = None) -> list[Any]:
    """The 3-D jobs of the sites `plan` visits (default: plan.json); the sites keep their
    index in sites.json (which seeds their simulation) whichever plan visits them."""
    from mound.survey.site_work import DENSE_RESOLUTION_M, SiteJob

    a = ctx.args
    sites_doc = read_json(ctx.tree.sites, "mound.sites", 1)
    if plan is None:
        plan = read_json(ctx.tree.plan, "mound.plan", 1)
    from mound.uav.mission_items import visited_ids

    tour = visited_ids(plan)
    root = ctx.tree.root.resolve()
    options: dict[str, Any] = {"image_size": tuple(a.image_size), "pattern": a.scan_pattern,
               "site_diameter_m": a.site_diameter, "sim_seed": a.sim_seed,
               "recon_args": ("--max-features", str(a.max_features)),
               "dense_args": ("--max-image-size", str(a.dense_size), "--resolution-m",
                              str(DENSE_RESOLUTION_M)) if a.dense_size > 0 else (),
               "verdict_args": ("--reference", str(Path(a.reference).resolve()))
               if a.reference else (), "threads": a.site_threads,
               "timeout_s": a.site_timeout,
               "dense_model": str(Path(a.verdict_model).resolve()) if a.verdict_model
               else None}
    jobs = []
    grounds = {n["id"]: n["ground_amsl_m"]
               for n in (sites_doc.get("terrain") or {}).get("nodes", [])}
    photos = images_root(ctx)
    for index, s in enumerate(sites_doc["sites"]):
        if s["id"] not in tour:
            continue
        ter = ({"dem": str(Path(a.dem).resolve()), "vertical": sites_doc["terrain"]["vertical"],
                "ground_amsl_m": grounds[s["id"]]} if a.dem and s["id"] in grounds else None)
        images = str((photos / s["id"]).resolve()) if photos else None
        second = ctx.tree.second_photos / s["id"]
        second_images = (str(second.resolve()) if a.second_photos and second.is_dir()
                         else None)
        first = {"site": {k: s.get(k) for k in ("id", "x_m", "y_m", "truth", "simulate")},
                 "index": index, "options": options, "images": images,
                 "images_digest": _folder_digest(Path(images)) if images else None,
                 "reference": sha256_of(Path(a.reference)) if a.reference else None,
                 **({"verdict_model": sha256_of(Path(a.verdict_model))}
                    if a.verdict_model else {}),
                 "terrain": ter and {**ter, "dem": ctx.terrain}}
        # the second card changes the site's key, not its first look's (site_work reuses it)
        key = digest({**first, **({"second_images": _folder_digest(second)}
                                  if second_images else {})})
        jobs.append(SiteJob(site=s, index=index, run_root=str(root), run_id=ctx.run_id,
                            origin=sites_doc["origin"], key=key, first_key=digest(first),
                            images_dir=images,
                            second_images_dir=second_images, terrain=ter, **options))
    return jobs


def _reusable(job: Any) -> dict[str, Any] | None:
    path = job.tree.result
    if not path.is_file():
        return None
    try:
        row = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    if row.get("key") != job.key:
        return None
    if row.get("status") == "ok" or row.get("retry") is False:
        return row
    return None


def run_jobs(ctx: Context, jobs: list[Any], tag: str = "sites3d"
             ) -> tuple[dict[str, dict[str, Any]], str, bool]:
    """Runs the site jobs not done before (on Dask); returns their rows by id, a note and
    whether every failure is final (the stage is complete)."""
    from mound.survey import cluster

    a = ctx.args
    rows: dict[str, dict[str, Any]] = {}
    todo = []
    for job in jobs:
        row = None if STAGES.index("sites3d") >= ctx.redo_from else _reusable(job)
        if row is not None:
            rows[job.site["id"]] = row
        else:
            todo.append(job)
    if todo:
        ctx.say(f"[{tag}] {len(todo)} of {len(jobs)} visited sites to process "
                f"({len(jobs) - len(todo)} done before)")
        with cluster.client_for(a.scheduler, a.workers) as client:
            ctx.say(f"[{tag}] Dask {cluster.describe(client)}")

            def on_row(row: dict[str, Any]) -> None:
                rows[row["id"]] = row
                if "schema" not in row:  # the task died before writing its row
                    job = next(j for j in todo if j.site["id"] == row["id"])
                    write_json(job.tree.result, row)

            cluster.run_sites(client, todo, ctx.run_id, on_row, progress=not a.no_progress)
    ok = [r for r in rows.values() if r.get("status") == "ok"]
    failed = [r for r in rows.values() if r.get("status") != "ok"]
    mounds = sum(1 for r in ok if r.get("verdict") == "mound")
    note = (f"{len(jobs)} visited sites: {len(ok)} judged ({mounds} mound, "
            f"{len(ok) - mounds} no mound), {len(failed)} failed")
    for r in failed:
        ctx.say(f"[{tag}] {r['id']} failed: {r.get('reason', '?')}")
    bugs = [r for r in failed if r.get("internal_error")]
    if bugs:  # every row is written: the same command resumes once the bug is fixed
        raise SiteBugError(f"{len(bugs)} site(s) hit an internal error (a bug; the traceback "
                           f"is in each site's log.txt): {bugs[0]['id']}: {bugs[0]['reason']}")
    return rows, note, all(r.get("retry") is False for r in failed)


class SiteBugError(RuntimeError):
    """A site's work raised an error that is neither bad input nor a tool's failure: a bug.
    The survey stops with exit 1 after every site of the stage is done."""


def stage_sites3d(ctx: Context) -> str:
    jobs = site_jobs(ctx)

    def work() -> tuple[list[str], str, bool]:
        rows, note, complete = run_jobs(ctx, jobs)
        root = ctx.tree.root.resolve()
        outputs = [str(j.tree.result.relative_to(root)) for j in jobs]
        made, said = second_look_missions(ctx, list(rows.values()), ctx.tree.plan,
                                          ctx.tree.sites)
        return outputs + made, note + said, complete

    return run_stage(ctx, "sites3d", {"plan": ctx.keys["plan"], "photos": ctx.keys["photos"],
                                      "sites": [j.key for j in jobs]}, work)


def second_look_missions(ctx: Context, rows: list[dict[str, Any]], plan_path: Path,
                         sites_path: Path) -> tuple[list[str], str]:
    """The missions of the second looks the verdicts advised (mound.uav.second_look) in
    DIR/second_look/: mission.plan, .waypoints, .geojson per flight (mission_2.plan, ...
    when they take several) and mission.json (mound.mission v1 with `second_look`: the
    sites, the scan factor, the sites refused and why). A real aircraft flies them; the
    survey's simulated sites were flown again at once. Returns the files and a note."""
    from mound.uav.second_look import advised_sites, second_look_flights

    t = ctx.tree
    out = t.second_look
    if out.is_dir():  # an earlier run's missions: the verdicts decide again
        shutil.rmtree(out)
    ids, factor = advised_sites(rows)
    if not ids or factor is None:
        return [], ""
    plan = read_json(plan_path, "mound.plan", 1)
    sites_doc = read_json(sites_path, "mound.sites", 1)
    flights, refused, spec = second_look_flights(sites_doc, plan, ids, factor,
                                                 mission_terrain(ctx.args))
    out.mkdir(parents=True)
    several = len(flights) > 1
    written, summary = write_missions(
        [(k if several else None, m) for k, m in enumerate(flights, start=1)], out, out,
        ctx.args.firmware, ctx.args.aircraft) if flights else ([], {
            "schema": "mound.mission", "version": 1, "origin": plan.get("origin"),
            "items": 0, "flight_distance_m": 0.0, "budget_m": float(sites_doc["budget_m"]),
            "flights": []})
    made = [str(p.relative_to(t.root)) for p in written]
    summary["second_look"] = {"sites": ids, "scan_factor": factor,
                              "site_diameter_m": spec.scan.scale_m,
                              "flown": [x["id"] for m in flights for x in m.sites],
                              "refused": refused}
    write_json(out / "mission.json", summary)
    made.append(str((out / "mission.json").relative_to(t.root)))
    # the flights as a plan (mound.plan v1): what `mound sim flight` writes a card of and
    # --second-photos sorts the second card by
    reward = {str(x["id"]): float(x.get("reward", 0.0)) for x in sites_doc["sites"]}
    tours = [[plan["tour"][0], *(x["id"] for x in m.sites), plan["tour"][-1]]
             for m in flights]
    sl_plan = {"schema": "mound.plan", "version": 1, "origin": plan["origin"],
               "algo": "second_look", "closed": plan.get("closed", True),
               "budget_m": float(sites_doc["budget_m"]), "scan": spec.scan.to_doc(),
               "tour": tours[0] if tours else [plan["tour"][0], plan["tour"][-1]],
               "waypoints": [w for w in plan.get("waypoints", [])
                             if w.get("kind") in ("home", "end")]
               + [{"id": x["id"], "x_m": x["x_m"], "y_m": x["y_m"], "kind": "site",
                   "scan_cost_m": spec.scan.site_cost_m()} for m in flights for x in m.sites],
               "n_visited": sum(len(m.sites) for m in flights),
               "reward": sum(reward.get(x["id"], 0.0) for m in flights for x in m.sites),
               "cost_m": summary["flight_distance_m"],
               "flights": [{"tour": tour, "reward": sum(reward.get(x["id"], 0.0)
                                                        for x in m.sites),
                            "cost_m": m.flight_distance_m,
                            "budget_left_m": m.budget_m - m.flight_distance_m}
                           for tour, m in zip(tours, flights, strict=True)]}
    write_json(out / "plan.json", sl_plan)
    made.append(str((out / "plan.json").relative_to(t.root)))
    note = (f"; second looks advised for {len(ids)} sites: {len(flights)} mission"
            f"{'s' if several else ''} with a {spec.scan.scale_m:.0f} m scan, "
            f"{summary['flight_distance_m']:.0f} m in all (second_look/)"
            + (f", {len(refused)} refused ({refused[0]['id']}: {refused[0]['reason']})"
               if refused else ""))
    ctx.say(f"[second look]{note[1:]}")
    return made, note


def stage_report(ctx: Context, started: float) -> str:
    from mound.survey import report

    def work() -> tuple[list[str], str, bool]:
        summary = report.build_summary(ctx.tree, ctx.args, ctx.stages, started)
        report.write_reports(ctx.tree, summary)  # adds the map page's name
        write_json(ctx.tree.summary, summary)
        m = summary["metrics"]
        fmt = (lambda v: "n/a" if v is None else f"{v:.3f}")  # noqa: E731
        return (["summary.json", "report.html", "report.md"]
                + (["map.html"] if summary.get("map") else []),
                f"eps_MD {fmt(m['eps_md'])}, eps_FA {fmt(m['eps_fa'])} (classifier alone: "
                f"{fmt(m['classifier_only']['eps_md'])}, "
                f"{fmt(m['classifier_only']['eps_fa'])}) -> {ctx.tree.report_html}", True)

    # The report always reflects this run's stage table, so it is rebuilt every time
    # (a few seconds); its key still records what it was built from.
    ctx.redo_from = min(ctx.redo_from, STAGES.index("report"))
    return run_stage(ctx, "report", {k: ctx.keys.get(k) for k in STAGES[:-1]}, work)


def run(argv: list[str]) -> int:
    args = SurveyOptions.from_namespace(build_parser().parse_args(argv))
    args.check()
    started = time.time()
    tree = RunTree(Path(args.out))
    tree.root.mkdir(parents=True, exist_ok=True)
    ctx = Context(args, tree, Ledger(tree.ledger))
    if args.force:
        ctx.redo_from = 0
    elif args.rerun_from:
        ctx.redo_from = STAGES.index(args.rerun_from)
    ctx.say(f"survey -> {tree.root} ({os.cpu_count()} cores)")
    stage_classify(ctx)
    stage_field(ctx)
    stage_plan(ctx)
    stage_mission(ctx)
    stage_photos(ctx)
    if args.learn:
        from mound.survey.learn import stage_learn

        stage_learn(ctx)
    else:
        stage_sites3d(ctx)
    stage_report(ctx, started)
    total = time.time() - started
    summary = read_json(tree.summary, SCHEMA, VERSION)
    ctx.say(f"done in {total:.1f} s ({summary['status']}): {tree.summary}, {tree.report_html}")
    return EXIT_NO_RESULT if summary["status"] == "failed" else 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        return run(argv)
    except KeyboardInterrupt:
        print("\nmission.py: interrupted; run the same command again to resume",
              file=sys.stderr)
        return 130
    except Exception as e:
        return exit_for("mission.py", e)

