"""The field stage: the candidate sites (the paper's field, the user's --sites file, or a
scene's candidates)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.formats.sites import Sites
from mound.geojson import point_feature_doc
from mound.geometry.flight import LEGACY_DIAMETER, ScanSpec
from mound.geometry.geodesy import Origin
from mound.jsonio import load_json, read_json, write_json
from mound.survey.context import Context, digest_files, run_stage, scan_spec
from mound.survey.reward import describe


def scene_sites(ctx: Context, scan: ScanSpec) -> Sites:
    """Scores each scene, merges their candidates (best first), gives each the truth of the
    labels within 15 m (a known mound, with its height_m; an explicit not_mound), and reads
    them as the run's sites; the others are simulated as flat ground, truth unknown."""
    from scipy.spatial import cKDTree

    from mound.args import parse_lat_lon, parse_names
    from mound.datasets import sha256_of as digest_of
    from mound.formats.sites import load_user_sites
    from mound.geometry.flight import flight_budget_m
    from mound.jsonio import read_json as read_doc
    from mound.scene import score
    from mound.scene.model import SCHEMA as SCENE_SCHEMA
    from mound.scene.model import VERSION as SCENE_VERSION
    from mound.scene.model import SceneModel
    from mound.scene.raster import open_scene, transformer_to_scene
    from mound.scene.train import FOUND_RADIUS_M
    from mound.scene.vector import read_aoi, read_labels

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
        cands = load_json(out / "candidates.geojson")["features"]
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
                    h = lb.props.get("height_m")
                    if lb.mound and isinstance(h, int | float):
                        pr["truth"]["height_m"] = float(h)
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
        point_feature_doc(home, {"kind": "home"}), *feats]}
    path = ctx.tree.root / "scene" / "candidates.geojson"
    write_json(path, gj)
    read = load_user_sites(path, scan, a.budget, flight_budget_m(), need_truth=False)
    by_id = {f["properties"]["id"]: f["properties"] for f in feats}
    # truth unknown: flown over flat ground, not counted
    sites = [replace(s, extra={**s.extra, "scene": {k: by_id[s.id][k] for k in (
        "scene", "scene_dir", "x", "y", "rank")}, **({} if s.truth else {"simulate": "flat"})})
        for s in read.sites]
    return read.with_sites(sites, provenance={**read.extra["provenance"],
                                              "tool": "python/mission.py --scene",
                                              "scenes": a.scenes})


def scan_as_before(material: dict[str, object]) -> None:
    """The scan's site diameter under its name until 2026-11-30 (`scale_m`) in the stage's
    material, so that a run (a field day) begun before keeps its stages across the rename."""
    sites = material.get("sites")
    for holder in (material, sites if isinstance(sites, dict) else {}):
        scan = holder.get("scan")
        if isinstance(scan, dict) and "site_diameter_m" in scan:
            holder["scan"] = {(LEGACY_DIAMETER if k == "site_diameter_m" else k): v
                              for k, v in scan.items()}


def stage_field(ctx: Context) -> str:
    from mound.classify import statlog
    from mound.classify.model import SCHEMA as MODEL_SCHEMA
    from mound.classify.model import VERSION as MODEL_VERSION
    from mound.classify.model import Model
    from mound.formats.sites import load_user_sites
    from mound.geometry.flight import flight_budget_m
    from mound.plan.field import make_field, sites_document

    a = ctx.args
    scan = scan_spec(a)
    if a.scene:
        material: dict[str, object] = {
            "classify": ctx.keys["classify"], "scan": scan.to_doc(), "budget": a.budget,
            "labels": digest_files([a.labels]) if a.labels else None, "home": a.home,
            "aoi": digest_files([a.aoi]) if a.aoi else None, "n": a.candidates,
            "sep": a.min_separation_m}
    elif a.sites:
        # Validated now, before anything is planned or flown, even when the stage is
        # skipped: a bad file must stop the run here.
        given = load_user_sites(a.sites, scan, a.budget, flight_budget_m(),
                                need_truth=not (a.images_root or a.photos))
        material = {"sites": given.to_doc()}
    else:
        material = {"classify": ctx.keys["classify"], "seed": a.field_seed,
                    "spacing": a.spacing, "scan": scan.to_doc(), "budget": a.budget,
                    "home": a.home}
    material["terrain"] = ctx.terrain
    scan_as_before(material)
    if a.reward != "entropy":  # (entropy: the material of runs before --reward)
        from mound.survey.reward import confusion_digest

        material["reward"] = [a.reward, confusion_digest(a.confusion)]

    def work() -> tuple[list[str], str, bool]:
        if a.scene:
            out = scene_sites(ctx, scan)
        elif a.sites:
            out = given
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
                out = replace(out, origin=Origin(home[0], home[1], 0.0))
        if a.reward != "entropy":
            from mound.survey.reward import reward_of, with_rewards

            out = with_rewards(out, reward_of(a.reward, a.confusion), a.reward)
        if a.dem:
            from mound.flightplan import terrain

            out = terrain.attach(out, a.dem, a.terrain_spec(), a.dem_vertical, out.origin)
        write_json(ctx.tree.sites, out.to_doc())
        prov = out.extra["provenance"]
        what = (f"field seed {a.field_seed}" if not (a.sites or a.scene) else
                f"{a.sites}" if a.sites else f"{len(a.scenes)} scene(s)")
        return (["sites.json"], f"{what}: {len(out.sites)} sites, {prov['positives']} "
                f"true mounds, total reward {prov['total_reward']:.2f} "
                f"{describe(a.reward)}, scan cost "
                f"{out.sites[0].scan_cost_m:.0f} m per site"
                f"{' (energy, over the DEM)' if a.dem else ''}, budget "
                f"{out.budget_m:.0f} m", True)

    return run_stage(ctx, "field", material, work)
