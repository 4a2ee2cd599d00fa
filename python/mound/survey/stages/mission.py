"""The mission stage: the tour's MAVLink missions (and the DJI and Litchi files), uploaded
and read back with --connect."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from mound.errors import InputError
from mound.formats.mission import FlightSummary, MissionSummary
from mound.formats.plan import Plan
from mound.jsonio import write_all_atomic, write_json
from mound.survey.context import Context, mission_terrain, run_stage
from mound.uav.mission_items import Mission


def write_missions(missions: list[tuple[int | None, Mission]], folder: Path, png_folder: Path,
                   firmware: str, aircraft: str = "m3e") -> tuple[list[Path], MissionSummary]:
    """Each flight's mission (k None: the only one) in every registered format
    (uav/mission_format.py: mission.plan, .waypoints, .geojson, .kmz for `aircraft`, .csv
    in parts past 99 waypoints, ...; mission_K.* of several), and its map
    PNG_FOLDER/mission.png (mission_K.png); returns the files and the mound.mission
    summary: the only flight's own, or of several their totals, each under `flights`. A
    format a limit of its own refuses is not written, and the summary's `formats` says why
    (the .plan is the reference and is always written)."""
    from mound.survey import figures
    from mound.uav import files as mission_files
    from mound.uav import mission_format

    written: list[Path] = []
    summaries: list[FlightSummary] = []
    for k, m in missions:
        opts = mission_format.WriteOptions(firmware, aircraft, "relative", m.terrain is not None)
        paths = {f.name: mission_files.flight_path(folder / f"mission{f.suffix}", k)
                 for f in mission_format.registry()}
        mission_format.check(paths, opts)
        files, formats = mission_format.write_flight(m, paths, opts)
        write_all_atomic(files)
        png = mission_files.flight_path(png_folder / "mission.png", k)
        figures.mission_map(m.nav_enu, m.footprints, m.sites, png)
        written += [*(p for p, _ in files), png]
        summaries.append(replace(m.summary(), flight=k or 1,
                                 file=paths[mission_format.reference().name].name,
                                 formats=formats))
    return written, MissionSummary(tuple(summaries), summaries[0].budget_m)


def stage_mission(ctx: Context) -> str:
    from mound.survey import figures
    from mound.uav import mission, mission_items
    from mound.uav.upload import upload_mission

    a = ctx.args
    t = ctx.tree

    def work() -> tuple[list[str], str, bool]:
        if a.cards is not None:  # the day planned once is not what the crew flies
            return [], ("a day on cards: each battery's missions are written as the day "
                        "goes, in battery_K/"), True
        plan = Plan.read(t.plan)
        if not plan.visited():
            return [], "nothing to fly: no site fits the budget", True
        if plan.origin is None:
            raise InputError(f"{t.plan}: origin: missing (the mission is flown in WGS84)")
        origin = plan.origin
        # The plan's scan, read once for every flight (build's own rule: else the default).
        scan = plan.scan()
        spec = mission_items.MissionSpec(scan=scan) if scan else mission_items.MissionSpec()
        terrain = mission_terrain(a)
        flights = mission_items.flight_plans(plan)
        several = len(flights) > 1
        missions = [(k if several else None, mission.build(f, origin, spec, terrain))
                    for k, f in flights]
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
                note += (f", over the DEM: energy {m.terrain.energy_m:.0f} m, lowest "
                         f"transit clearance {m.terrain.lowest_clearance_m or 0:.1f} m")
            notes.append(note)
        for f in summary.flights:
            for fmt in (f.formats or {}).values():
                if fmt.refused is not None:
                    notes.append(f"flight {f.flight}: {fmt.refused} (not written)")
        note = "; ".join(notes)
        if missions[0][1].terrain is None:
            note += "; terrain not checked (no --dem)"
        if a.connect:
            first = t.flight_file("mission.plan", missions[0][0])
            r = upload_mission(first, a.connect, verify=True, firmware=a.firmware)
            summary = replace(summary, upload=r)
            note += (f"; {first.name} uploaded to system {r.target_system} and read back "
                     f"({r.elapsed_s:.2f} s)")
        else:
            note += "; not uploaded (no --connect)"
        write_json(t.mission_summary, summary.to_doc())
        return ([*made, "mission.json"], note, True)

    return run_stage(ctx, "mission", {"plan": ctx.keys["plan"], "connect": a.connect,
                                      **({"cards": True} if a.cards is not None else {}),
                                      "firmware": a.firmware, "aircraft": a.aircraft,
                                      "terrain": ctx.terrain}, work)
