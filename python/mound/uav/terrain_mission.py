"""The mission over real terrain, heights planned above mean sea level (uav/mission_items.py
says how they are written; flightplan/terrain.py how they are chosen and what a flight costs)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.flightplan.terrain import (
    TerrainModel,
    TerrainNode,
    climb_descent_m,
    energy_m,
    open_dem,
)
from mound.formats.mission import ClearanceSpec, FlightTerrain, LegProfile, TerrainLeg
from mound.formats.plan import Plan
from mound.geometry.flight import path_length
from mound.geometry.geodesy import Origin
from mound.uav import mission_items as mi

PROFILE_SAMPLES = 120  # terrain samples per leg in the profiles (report, GeoJSON)


def build_over_terrain(plan: Plan, origin: Origin, spec: mi.MissionSpec,
                       terrain: mi.TerrainInput, nodes: list[TerrainNode], closed: bool,
                       budget: float) -> mi.Mission:
    tspec = terrain.spec if terrain.spec is not None else ClearanceSpec()
    tspec.check()
    scan = spec.scan
    # The tour's nodes once each (a closed tour's return to home is node 0 again).
    stops = nodes[:-1] if closed else nodes
    model_nodes = list(stops)
    xy = np.array([[n.x_m, n.y_m] for n in model_nodes])
    dem = open_dem(terrain.dem_path, origin, terrain.vertical, xy, scan, tspec)
    tspec = replace(tspec, vertical=dem.vertical)
    model = TerrainModel(dem, tspec, scan, model_nodes)
    model.check_scans()
    order = list(range(len(stops))) + ([0] if closed else [])
    legs_from, legs_to = np.array(order[:-1]), np.array(order[1:])
    heights, tops, where = model.leg_heights(legs_from, legs_to)
    home_amsl = float(model.ground[0])

    w = mi.ItemWriter(origin, home_amsl, np.array([xy[0, 0], xy[0, 1], home_amsl]))
    sites_out: list[mi.MissionSite] = []
    footprints: list[mi.Footprint] = []
    legs: list[TerrainLeg] = []
    legs_from_item: list[int] = []  # where each leg's climb starts in the path
    for k, (a, b) in enumerate(zip(legs_from, legs_to, strict=True)):
        h = float(heights[k])
        ea = model.exit_xy[a]
        eb = model.entry_xy[b]
        start = len(w.path) - 1
        if k == 0:
            w.nav(mi.NAV_TAKEOFF, np.array([ea[0], ea[1], h]))
            w.do(mi.DO_CHANGE_SPEED, (1.0, spec.cruise_speed_m_s, -1.0, 0.0))
        else:
            w.nav(mi.NAV_WAYPOINT, np.array([ea[0], ea[1], h]))  # climb in place
        w.nav(mi.NAV_WAYPOINT, np.array([eb[0], eb[1], h]))      # level over the terrain
        legs.append(TerrainLeg(
            model_nodes[a].id, model_nodes[b].id, h, float(tops[k]),
            (round(float(where[k, 0]), 2), round(float(where[k, 1]), 2)), h - float(tops[k]),
            model.leg_cost(int(a), int(b), h)))
        legs_from_item.append(start)
        if not model.is_site[b]:
            w.nav(mi.NAV_LAND, np.array([eb[0], eb[1], float(model.ground[b])]),
                  (0.0, 0.0, 0.0, mi.NAN))
            continue
        g = float(model.ground[b])
        scan_start = len(w.path) - 1
        images, fps = w.scan_site(spec, np.array([model.xy[b, 0], model.xy[b, 1], g]),
                                  model_nodes[b].id, model.legs)
        footprints += fps
        node = stops[b]
        sites_out.append(mi.MissionSite(
            node.id, node.x_m, node.y_m, path_length(np.array(w.path[scan_start:])), images,
            node.scan_cost_m, g, tuple(float(leg.points_enu[0, 2]) for leg in model.legs)))

    pts = np.array(w.path)
    energy = energy_m(pts, tspec.climb_factor, tspec.descent_factor)
    climbed, descended = climb_descent_m(pts)
    if energy > budget * (1 + spec.budget_slack) + 1e-6:
        worst = max(legs, key=lambda leg: leg.cost_m)
        raise InputError(
            f"mission: leg {worst.from_id} -> {worst.to_id} climbs to "
            f"{worst.transit_amsl_m:.1f} m AMSL to clear the terrain at ENU "
            f"({worst.terrain_max_enu_m[0]:.1f}, {worst.terrain_max_enu_m[1]:.1f}) m "
            f"({worst.terrain_max_amsl_m:.1f} m + "
            f"{tspec.clearance_m:g} m clearance); the flight then costs {energy:.1f} m of "
            f"energy, over the plan's budget_m {budget:g} m (refused, never flown lower; "
            "plan with the DEM: mound field make --dem)")
    legs = [replace(leg, profile=_profile(k, pts, dem))
            for leg, k in zip(legs, legs_from_item, strict=True)]
    nav_rel = [p - np.array([0.0, 0.0, home_amsl]) for p in w.path]
    terrain_doc = FlightTerrain(dem.path, dem.crs_name, home_amsl, tspec, energy, climbed,
                                descended, plan.flights[0].cost_m, tuple(legs))
    return mi.Mission(w.items, origin, path_length(pts), budget, closed, sites_out, nav_rel,
                      footprints, spec, terrain_doc, w.scans)


def _profile(start: int, pts: np.ndarray, dem: Any) -> LegProfile:
    """Distance along a leg's horizontal part vs terrain height vs flight height (AMSL):
    from the climb point (pts[start + 1]) to the point over the next site (pts[start + 2])."""
    a, b = pts[start + 1], pts[start + 2]
    n = PROFILE_SAMPLES
    t = np.linspace(0.0, 1.0, n)
    xy = a[None, :2] + (b[:2] - a[:2])[None] * t[:, None]
    ground = dem.height(xy, "a leg's profile")
    dist = np.hypot(*(b[:2] - a[:2])) * t
    return LegProfile(tuple(np.round(dist, 2).tolist()), tuple(np.round(ground, 2).tolist()),
                      float(a[2]), (float(a[0]), float(a[1])), (float(b[0]), float(b[1])))
