"""The sites3d stage: each visited site's 3-D work on Dask (site_work.py), the second
looks' missions; learn.py flies it flight by flight."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

from mound.datasets import sha256_of
from mound.jsonio import read_json, write_json
from mound.survey.context import (
    STAGES,
    Context,
    folder_digest,
    images_root,
    mission_terrain,
    run_stage,
)
from mound.survey.ledger import digest
from mound.survey.stages.mission import write_missions


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
                 "images_digest": folder_digest(Path(images)) if images else None,
                 "reference": sha256_of(Path(a.reference)) if a.reference else None,
                 **({"verdict_model": sha256_of(Path(a.verdict_model))}
                    if a.verdict_model else {}),
                 "terrain": ter and {**ter, "dem": ctx.terrain}}
        # the second card changes the site's key, not its first look's (site_work reuses it)
        key = digest({**first, **({"second_images": folder_digest(second)}
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
