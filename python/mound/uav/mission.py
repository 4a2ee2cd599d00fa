"""The mission of a planned tour: its MISSION_ITEM_INTs (written by
mission_items.ItemWriter, whose module text says what they are) with heights in one of two
frames — above home with the ground taken flat (below), or following a DEM's terrain
(terrain_mission.py)."""

from __future__ import annotations

import numpy as np

from mound.errors import InputError
from mound.flightplan.terrain import TerrainNode
from mound.formats.plan import Plan
from mound.geometry.flight import path_length
from mound.geometry.geodesy import Origin
from mound.uav.mission_items import (
    DO_CHANGE_SPEED,
    FRAME_MISSION,
    NAN,
    NAV_LAND,
    NAV_RETURN_TO_LAUNCH,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
    Footprint,
    ItemWriter,
    Mission,
    MissionItem,
    MissionSite,
    MissionSpec,
    TerrainInput,
    plan_nodes,
    up,
)
from mound.uav.terrain_mission import build_over_terrain


def build(plan: Plan, origin: Origin, spec: MissionSpec | None = None,
          terrain: TerrainInput | None = None) -> Mission:
    """The mission for a plan of one flight; InputError if it breaks the budget. Without
    `spec`, the plan's own scan (Plan.scan) or the default one is flown. With `terrain`
    (a DEM) the heights follow the ground (see mission_items' module text)."""
    if spec is None:
        scan = plan.scan()
        spec = MissionSpec(scan=scan) if scan is not None else MissionSpec()
    spec.check()
    nodes, closed, budget = plan_nodes(plan)
    if len(nodes) <= 2 and (closed or len(nodes) < 2):
        raise InputError("tour: the plan visits no site, there is nothing to fly")
    plan_terrain = plan.extra.get("terrain")
    if terrain is None and isinstance(plan_terrain, dict):
        dem = plan_terrain.get("dem", "its DEM")
        raise InputError(f"plan.terrain: the plan was made over {dem!s:.200} (its costs count "
                         "the climbs); build its mission with --dem, or the heights would be "
                         "above home with the terrain not checked")
    if terrain is not None:
        return build_over_terrain(plan, origin, spec, terrain, nodes, closed, budget)
    return _flat(origin, spec, nodes, closed, budget)


def _flat(origin: Origin, spec: MissionSpec, nodes: list[TerrainNode], closed: bool,
          budget: float) -> Mission:
    """Heights above home, every site's ground taken at home's height: one transit
    height, the flight distance checked against the budget."""
    legs = spec.scan.legs()
    transit = spec.scan.transit_m(legs)
    home = np.array([nodes[0].x_m, nodes[0].y_m, 0.0])
    w = ItemWriter(origin, 0.0, home)
    w.nav(NAV_TAKEOFF, home + up(transit), (0.0, 0.0, 0.0, NAN))
    w.do(DO_CHANGE_SPEED, (1.0, spec.cruise_speed_m_s, -1.0, 0.0))
    sites_out: list[MissionSite] = []
    footprints: list[Footprint] = []
    for node in nodes[1:-1] if len(nodes) > 2 else []:
        centre = np.array([node.x_m, node.y_m, 0.0])
        entry = centre + legs[0].points_enu[0]
        w.nav(NAV_WAYPOINT, np.array([entry[0], entry[1], transit]))
        scan_start = len(w.path) - 1
        images, fps = w.scan_site(spec, centre, node.id, legs)
        footprints += fps
        sites_out.append(MissionSite(node.id, node.x_m, node.y_m,
                                     path_length(np.array(w.path[scan_start:])), images,
                                     node.scan_cost_m))
    end = np.array([nodes[-1].x_m, nodes[-1].y_m, 0.0])
    if closed:
        w.items.append(MissionItem(NAV_RETURN_TO_LAUNCH, FRAME_MISSION))
        w.path += [home + up(transit), home.copy()]
    else:
        w.nav(NAV_WAYPOINT, end + up(transit))
        w.nav(NAV_LAND, end, (0.0, 0.0, 0.0, NAN))
    distance = path_length(np.array(w.path))
    if distance > budget * (1 + spec.budget_slack) + 1e-6:
        worst = max(sites_out, key=lambda s: s.scan_length_m - s.scan_cost_m, default=None)
        hint = (f"; a {spec.scan.pattern} scan flies {worst.scan_length_m:.0f} m per site, the "
                f"plan assumed scan_cost_m {worst.scan_cost_m:g}") if worst else ""
        raise InputError(f"mission: flight distance {distance:.1f} m exceeds the plan's "
                         f"budget_m {budget:g} m{hint}")
    return Mission(w.items, origin, distance, budget, closed, sites_out, w.path, footprints,
                   spec, scans=w.scans)
