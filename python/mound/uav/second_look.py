"""The second look's missions: the sites a first verdict left undecided (verdict.json
`second_look.advised`, mound.verdict_model's `second_look` band) flown again with a scan
`scan_factor` x as wide, as MAVLink missions an aircraft can fly.

The survey simulates a second look at once; a real aircraft needs a mission, and the wider
scan (4 x the area for a scan 2 x as wide) must fit a flight's budget like any other. The
sites are taken in the order the survey's tour visited them (a tour restricted to some of
its sites is never longer, by the triangle inequality), home and end as the survey's, each
scanned with the survey's own scan (the plan's ScanSpec) scaled `scan_factor` x — the
flight mound.sim.looks.wider simulates. Flights are filled in that order: a site joins the
current flight when the mission built with it (mission.build, over the DEM when there
is one: heights that clear the terrain, energy within the budget) still passes, else it
opens the next flight. A site whose second look alone cannot be flown (its wide scan
breaks the budget, or the terrain check refuses it) is refused with the reason: never
flown lower, never over budget.
"""

from __future__ import annotations

import math
from dataclasses import replace

from mound.errors import InputError
from mound.formats.mission import Refusal
from mound.formats.plan import Flight, Plan, Waypoint
from mound.formats.site_row import SiteRow
from mound.formats.sites import Sites
from mound.uav.mission import build
from mound.uav.mission_items import Mission, MissionSpec, TerrainInput


def advised_sites(rows: list[SiteRow]) -> tuple[list[str], float | None]:
    """The ids of the site rows whose first verdict advised a second look, and its scan
    factor (the widest asked for; None without one)."""
    ids, factors = [], []
    for r in rows:
        look = r.second_look
        if look is not None and look.advised:
            f = look.scan_factor
            if f is None or not f >= 1:
                raise InputError(f"sites: {r.id}.second_look.scan_factor: expected a "
                                 f"number >= 1, got {f!r:.40}")
            ids.append(r.id)
            factors.append(float(f))
    return ids, (max(factors) if factors else None)


def second_look_flights(sites: Sites, plan: Plan | None, ids: list[str],
                        scan_factor: float, terrain: TerrainInput | None = None
                        ) -> tuple[list[Mission], list[Refusal], MissionSpec]:
    """The missions that fly the second looks of `ids` (see the module text), the sites
    refused (and why) and the wider scan's MissionSpec."""
    origin = plan.origin if plan is not None and plan.origin is not None else sites.origin
    if origin is None:
        raise InputError("plan: origin: missing (the missions are flown in WGS84)")
    scan = plan.scan() if plan else None
    base = MissionSpec(scan=scan) if scan is not None else MissionSpec()
    wide = base.scan.site_diameter_m * scan_factor
    spec = replace(base, scan=replace(base.scan, site_diameter_m=wide))
    spec.check()
    cost = spec.scan.site_cost_m()
    by_id = sites.by_id()
    home, end = sites.home, sites.end
    for i in ids:
        if i not in by_id:
            raise InputError(f"second look: site {i!r} is not in the sites document")
    rank = {i: k for k, i in enumerate(plan.visit_order() if plan else [])}
    ids = sorted(ids, key=lambda i: (rank.get(i, len(rank)), math.hypot(
        by_id[i].x_m - home.x_m, by_id[i].y_m - home.y_m)))
    plan_terrain = plan.extra.get("terrain") if plan else None

    def mission(visit: list[str]) -> Mission:
        wps = [Waypoint(home.id, home.x_m, home.y_m, "home")]
        wps += [Waypoint(i, by_id[i].x_m, by_id[i].y_m, "site", cost) for i in visit]
        if not sites.closed:
            wps.append(Waypoint(end.id, end.x_m, end.y_m, "end"))
        flight = Plan(
            "second_look", (Flight((home.id, *visit, end.id), None, None, None),),
            sites.budget_m, sites.closed, origin,
            extra={"terrain": plan_terrain} if plan_terrain is not None else {},
            waypoints=tuple(wps))
        return build(flight, origin, spec, terrain)

    def attempt(visit: list[str]) -> Mission | str:
        try:
            return mission(visit)
        except InputError as e:
            return str(e)

    flights: list[Mission] = []
    refused: list[Refusal] = []
    current: list[str] = []
    best: Mission | None = None
    for i in ids:
        got = attempt([*current, i])
        if isinstance(got, Mission):
            best, current = got, [*current, i]
            continue
        if best is not None:  # the flight so far is full: flown; the site opens the next
            flights.append(best)
            current, best = [], None
            got = attempt([i])
            if isinstance(got, Mission):
                best, current = got, [i]
                continue
        refused.append(Refusal(i, got))
    if best is not None:
        flights.append(best)
    return flights, refused, spec
