"""The sites3d stage: each visited site's 3-D work on Dask (site_work.py), the second
looks' missions; learn.py flies it flight by flight."""

from __future__ import annotations

import shutil
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, TypedDict

from mound.datasets import sha256_of
from mound.errors import InputError
from mound.formats.mission import MissionSummary, SecondLookMissions
from mound.formats.plan import Plan, Waypoint
from mound.formats.site_row import SiteRow
from mound.formats.sites import Sites
from mound.jsonio import write_json
from mound.sim.card import SiteGround
from mound.survey.context import (
    Context,
    folder_digest,
    images_root,
    mission_terrain,
    run_stage,
)
from mound.survey.ledger import digest
from mound.survey.stages.mission import write_missions


class JobOptions(TypedDict):
    """The survey's options every site's job takes (SiteJob's members of the same names);
    part of each site's key."""
    image_size: tuple[int, int]
    pattern: str
    site_diameter_m: float
    sim_seed: int
    threads: int
    timeout_s: float
    dense_model: str | None

def site_jobs(ctx: Context, plan: Plan | None = None,
              photos: Mapping[str, Path] | None = None) -> list[Any]:
    """The 3-D jobs of the sites `plan` visits (default: plan.json); the sites keep their
    index in sites.json (which seeds their simulation) whichever plan visits them. A day
    on cards gives each site's folder of photos (`photos`)."""
    from dataclasses import replace

    from mound.recon.defaults import SIM_RECONSTRUCT
    from mound.recon.tool_options import ReconstructOptions, VerdictOptions
    from mound.survey.site_work import SiteJob

    a = ctx.args
    # real photos (a card, or folders sorted by hand) get the tool's defaults (COLMAP's
    # keypoint density), the simulated sites the fast setting; --max-features N asks for
    # the fast setting with N features for both
    card = bool(a.photos or a.images_root or photos is not None)
    recon = (replace(SIM_RECONSTRUCT, max_features=a.max_features)
             if a.max_features is not None else ReconstructOptions() if card
             else SIM_RECONSTRUCT)
    dense = a.densify_options() if a.dense_size != 0 else None
    verdict = VerdictOptions(str(Path(a.reference).resolve()) if a.reference else None)
    sites_doc = Sites.read(ctx.tree.sites)
    if plan is None:
        plan = Plan.read(ctx.tree.plan)
    tour = plan.visited()
    root = ctx.tree.root.resolve()
    options: JobOptions = {
        "image_size": (a.image_size[0], a.image_size[1]), "pattern": a.scan_pattern,
        "site_diameter_m": a.site_diameter_m, "sim_seed": a.sim_seed,
        "threads": a.site_threads, "timeout_s": a.site_timeout,
        "dense_model": str(Path(a.verdict_model).resolve()) if a.verdict_model else None}
    tools = {"recon": recon.to_doc(), "dense": dense and dense.to_doc(),
             "verdict": verdict.to_doc()}
    jobs = []
    terrain = sites_doc.terrain() or {}
    grounds = {n["id"]: n["ground_amsl_m"] for n in terrain.get("nodes", [])}
    root_photos = images_root(ctx)
    if sites_doc.origin is None:
        raise InputError(f"{ctx.tree.sites}: origin: missing (the sites are flown in WGS84)")
    for index, s in enumerate(sites_doc.sites):
        if s.id not in tour:
            continue
        ter = (SiteGround(str(Path(a.dem).resolve()), terrain["vertical"], grounds[s.id])
               if a.dem and s.id in grounds else None)
        folder = (photos.get(s.id) if photos is not None
                  else root_photos / s.id if root_photos else None)
        images = str(folder.resolve()) if folder else None
        second_dir = ctx.tree.second_photos / s.id
        second_images = (str(second_dir.resolve()) if a.second_photos and second_dir.is_dir()
                         else None)
        first = {"site": {"id": s.id, "x_m": s.x_m, "y_m": s.y_m,
                          "truth": s.truth.to_doc() if s.truth else None,
                          "simulate": s.extra.get("simulate")},
                 "index": index, "options": {**options, **tools}, "images": images,
                 "images_digest": folder_digest(Path(images)) if images else None,
                 "reference": sha256_of(Path(a.reference)) if a.reference else None,
                 **({"verdict_model": sha256_of(Path(a.verdict_model))}
                    if a.verdict_model else {}),
                 "terrain": ter and {**ter.to_doc(), "dem": ctx.terrain}}
        # the second card changes the site's key, not its first look's (site_work reuses it)
        key = digest({**first, **({"second_images": folder_digest(second_dir)}
                                  if second_images else {})})
        jobs.append(SiteJob(site=s, index=index, run_root=str(root), run_id=ctx.run_id,
                            origin=sites_doc.origin, key=key, first_key=digest(first),
                            images_dir=images,
                            second_images_dir=second_images, terrain=ter, recon=recon,
                            dense=dense, verdict=verdict, **options))
    return jobs


def _reusable(job: Any) -> SiteRow | None:
    """The site's row of a run before with the same key, when it is final (judged, or a
    failure a rerun would repeat); an unreadable row is done again."""
    path = job.tree.result
    if not path.is_file():
        return None
    try:
        row = SiteRow.read(path)
    except InputError:
        return None
    if row.key == job.key and (row.ok or row.retry is False):
        return row
    return None


def run_jobs(ctx: Context, jobs: list[Any], tag: str = "sites3d"
             ) -> tuple[dict[str, SiteRow], str, bool]:
    """Runs the site jobs not done before (on Dask); returns their rows by id, a note and
    whether every failure is final (the stage is complete)."""
    from mound.survey import cluster

    a = ctx.args
    rows: dict[str, SiteRow] = {}
    todo = []
    for job in jobs:
        row = None if ctx.redoes("sites3d") else _reusable(job)
        if row is not None:
            rows[job.site.id] = row
        else:
            todo.append(job)
    if todo:
        ctx.say(f"[{tag}] {len(todo)} of {len(jobs)} visited sites to process "
                f"({len(jobs) - len(todo)} done before)")
        with cluster.client_for(a.scheduler, a.workers) as client:
            ctx.say(f"[{tag}] Dask {cluster.describe(client)}")

            def on_row(row: SiteRow) -> None:
                rows[row.id] = row

            cluster.run_sites(client, todo, ctx.run_id, on_row, progress=not a.no_progress)
    ok = [r for r in rows.values() if r.ok]
    failed = [r for r in rows.values() if not r.ok]
    mounds = sum(1 for r in ok if r.verdict is not None and r.verdict.two_answer == "mound")
    note = (f"{len(jobs)} visited sites: {len(ok)} judged ({mounds} mound, "
            f"{len(ok) - mounds} no mound), {len(failed)} failed")
    for r in failed:
        ctx.say(f"[{tag}] {r.id} failed: {r.reason or '?'}")
    bugs = [r for r in failed if r.internal_error]
    if bugs:  # every row is written: the same command resumes once the bug is fixed
        raise SiteBugError(f"{len(bugs)} site(s) hit an internal error (a bug; the traceback "
                           f"is in each site's log.txt): {bugs[0].id}: {bugs[0].reason}")
    return rows, note, all(r.retry is False for r in failed)


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


def second_look_missions(ctx: Context, rows: list[SiteRow], plan_path: Path,
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
    plan = Plan.read(plan_path)
    sites_doc = Sites.read(sites_path)
    flights, refused, spec = second_look_flights(sites_doc, plan, ids, factor,
                                                 mission_terrain(ctx.args))
    out.mkdir(parents=True)
    several = len(flights) > 1
    written, summary = write_missions(
        [(k if several else None, m) for k, m in enumerate(flights, start=1)], out, out,
        ctx.args.firmware, ctx.args.aircraft) if flights else (
            [], MissionSummary((), sites_doc.budget_m, plan.origin))
    made = [str(p.relative_to(t.root)) for p in written]
    summary = replace(summary, second_look=SecondLookMissions(
        tuple(ids), factor, spec.scan.site_diameter_m,
        tuple(x.id for m in flights for x in m.sites),
        tuple(refused)))
    write_json(out / "mission.json", summary.to_doc())
    made.append(str((out / "mission.json").relative_to(t.root)))
    # the flights as a plan (mound.plan v1): what `mound sim flight` writes a card of and
    # --second-photos sorts the second card by
    reward = {x.id: x.reward for x in sites_doc.sites}
    tours = [[plan.home, *(x.id for x in m.sites), plan.end] for m in flights]
    sl_plan = Plan.of_flights(
        "second_look", tours or [[plan.home, plan.end]],
        [sum(reward.get(x.id, 0.0) for x in m.sites) for m in flights] or [0.0],
        [m.flight_distance_m for m in flights] or [0.0], sites_doc.budget_m, plan.closed,
        plan.origin, scan=spec.scan.to_doc(),
        waypoints=[w for w in plan.waypoints if w.kind in ("home", "end")]
        + [Waypoint(x.id, x.x_m, x.y_m, "site", spec.scan.site_cost_m())
           for m in flights for x in m.sites],
        n_visited=sum(len(m.sites) for m in flights))
    write_json(out / "plan.json", sl_plan.to_doc())
    made.append(str((out / "plan.json").relative_to(t.root)))
    note = (f"; second looks advised for {len(ids)} sites: {len(flights)} mission"
            f"{'s' if several else ''} with a {spec.scan.site_diameter_m:.0f} m scan, "
            f"{summary.flight_distance_m:.0f} m in all (second_look/)"
            + (f", {len(refused)} refused ({refused[0].id}: {refused[0].reason})"
               if refused else ""))
    ctx.say(f"[second look]{note[1:]}")
    return made, note
