"""The mission over real terrain (uav/mission_items.py says how heights are written;
uav/terrain.py how they are chosen and what a flight costs)."""

from __future__ import annotations

from typing import Any

import numpy as np

from mound.errors import InputError
from mound.geometry.flight import path_length
from mound.geometry.geodesy import Origin, enu_to_geodetic
from mound.uav import mission_items as mi
from mound.uav.terrain import Node, TerrainModel, TerrainSpec, climb_descent_m, energy_m, open_dem

PROFILE_SAMPLES = 120  # terrain samples per leg in the profiles (report, GeoJSON)


def build_over_terrain(plan: dict[str, Any], origin: Origin, spec: mi.MissionSpec,
                       terrain: mi.TerrainInput, nodes: list[dict[str, Any]], closed: bool,
                       budget: float) -> mi.Mission:
    tspec = terrain.spec if terrain.spec is not None else TerrainSpec()
    tspec.validate()
    scan = spec.scan
    # The tour's nodes once each (a closed tour's return to home is node 0 again).
    stops = nodes[:-1] if closed else nodes
    model_nodes = [Node(str(n["id"]), n["kind"], n["x_m"], n["y_m"]) for n in stops]
    xy = np.array([[n.x_m, n.y_m] for n in model_nodes])
    dem = open_dem(terrain.dem_path, origin, terrain.vertical, xy, scan, tspec)
    tspec = TerrainSpec(**{**tspec.to_doc(), "vertical": dem.vertical})
    model = TerrainModel(dem, tspec, scan, model_nodes)
    model.check_scans()
    order = list(range(len(stops))) + ([0] if closed else [])
    legs_from, legs_to = np.array(order[:-1]), np.array(order[1:])
    heights, tops, where = model.leg_heights(legs_from, legs_to)
    home_amsl = float(model.ground[0])

    items: list[mi.MissionItem] = []
    path_amsl: list[np.ndarray] = [np.array([xy[0, 0], xy[0, 1], home_amsl])]

    def rel(z_amsl: float) -> float:
        return float(z_amsl) - home_amsl

    def geo(p: np.ndarray) -> tuple[int, int]:
        lat, lon, _ = enu_to_geodetic(origin, np.array([[p[0], p[1], 0.0]]))[0]
        return round(lat * 1e7), round(lon * 1e7)

    def nav(command: int, p_amsl: np.ndarray, params: tuple = (0.0, 0.0, 0.0, mi.NAN)) -> None:
        x, y = geo(p_amsl)
        items.append(mi.MissionItem(command, mi.FRAME_GLOBAL_RELATIVE_ALT_INT, params, x, y,
                                    rel(p_amsl[2])))
        path_amsl.append(np.asarray(p_amsl, dtype=float))

    def do(command: int, params: tuple, p_amsl: np.ndarray | None = None,
           frame: int = mi.FRAME_MISSION) -> None:
        x, y = geo(p_amsl) if p_amsl is not None else (0, 0)
        z = rel(p_amsl[2]) if p_amsl is not None else 0.0
        items.append(mi.MissionItem(command, frame, params, x, y, z))

    sites_out: list[dict[str, Any]] = []
    footprints: list[dict[str, Any]] = []
    leg_docs: list[dict[str, Any]] = []
    cam = scan.camera()
    legs = model.legs
    for k, (a, b) in enumerate(zip(legs_from, legs_to, strict=True)):
        h = float(heights[k])
        ea = model.exit_xy[a]
        eb = model.entry_xy[b]
        start = len(path_amsl) - 1
        if k == 0:
            nav(mi.NAV_TAKEOFF, np.array([ea[0], ea[1], h]))
            do(mi.DO_CHANGE_SPEED, (1.0, spec.cruise_speed_m_s, -1.0, 0.0))
        else:
            nav(mi.NAV_WAYPOINT, np.array([ea[0], ea[1], h]))  # climb in place
        nav(mi.NAV_WAYPOINT, np.array([eb[0], eb[1], h]))      # level over the terrain
        leg_docs.append({
            "from": model_nodes[a].id, "to": model_nodes[b].id, "transit_amsl_m": h,
            "terrain_max_amsl_m": float(tops[k]),
            "terrain_max_enu_m": [round(float(where[k, 0]), 2), round(float(where[k, 1]), 2)],
            "clearance_m": h - float(tops[k]),
            "cost_m": model.leg_cost(int(a), int(b), h),
            "path_from": start})
        if not model.is_site[b]:
            end_ground = np.array([eb[0], eb[1], float(model.ground[b])])
            nav(mi.NAV_LAND, end_ground, (0.0, 0.0, 0.0, mi.NAN))
            continue
        g = float(model.ground[b])
        centre = np.array([model.xy[b, 0], model.xy[b, 1], g])
        do(mi.DO_CHANGE_SPEED, (1.0, spec.scan_speed_m_s, -1.0, 0.0))
        scan_start = len(path_amsl) - 1
        images = 0
        for leg in legs:
            if leg.pattern == "orbit":
                do(mi.DO_SET_ROI_LOCATION, (0.0, 0.0, 0.0, 0.0),
                   centre + np.array([0.0, 0.0, scan.target_height_m]),
                   mi.FRAME_GLOBAL_RELATIVE_ALT_INT)
            do(mi.DO_SET_CAM_TRIGG_DIST, (leg.trigger_m, 0.0, 1.0, 0.0))
            for p in leg.points_enu:
                nav(mi.NAV_WAYPOINT, centre + p)
            do(mi.DO_SET_CAM_TRIGG_DIST, (0.0, 0.0, 0.0, 0.0))
            if leg.pattern == "orbit":
                do(mi.DO_SET_ROI_NONE, (0.0, 0.0, 0.0, 0.0))
            images += leg.images
            reach = 3 * float(leg.points_enu[:, 2].max())
            for q, pose in enumerate(leg.poses):
                corners = np.array([model.xy[b, 0], model.xy[b, 1], 0.0]) + mi.image_footprint(
                    cam, pose, reach)
                footprints.append({"site": model_nodes[b].id, "pattern": leg.pattern,
                                   "image": q, "corners_enu_m": corners.tolist()})
        do(mi.DO_CHANGE_SPEED, (1.0, spec.cruise_speed_m_s, -1.0, 0.0))
        scan_path = np.array(path_amsl[scan_start:])
        node = stops[b]
        sites_out.append({"id": node["id"], "x_m": node["x_m"], "y_m": node["y_m"],
                          "ground_amsl_m": g,
                          "scan_height_above_ground_m": [float(leg.points_enu[0, 2])
                                                         for leg in legs],
                          "scan_length_m": path_length(scan_path), "images": images,
                          "scan_cost_m": node["scan_cost_m"]})

    pts = np.array(path_amsl)
    energy = energy_m(pts, tspec.climb_factor, tspec.descent_factor)
    climbed, descended = climb_descent_m(pts)
    if energy > budget * (1 + spec.budget_slack) + 1e-6:
        costs = [d["cost_m"] for d in leg_docs]
        w = leg_docs[int(np.argmax(costs))]
        raise InputError(
            f"mission: leg {w['from']} -> {w['to']} climbs to {w['transit_amsl_m']:.1f} m AMSL "
            f"to clear the terrain at ENU ({w['terrain_max_enu_m'][0]:.1f}, "
            f"{w['terrain_max_enu_m'][1]:.1f}) m ({w['terrain_max_amsl_m']:.1f} m + "
            f"{tspec.clearance_m:g} m clearance); the flight then costs {energy:.1f} m of "
            f"energy, over the plan's budget_m {budget:g} m (refused, never flown lower; "
            "plan with the DEM: mound field make --dem)")
    for d in leg_docs:
        k = int(d.pop("path_from"))
        d["profile"] = _profile(model, k, pts, dem)
        d["profile_start_enu_m"] = [float(v) for v in pts[k + 1, :2]]
        d["profile_end_enu_m"] = [float(v) for v in pts[k + 2, :2]]
    nav_rel = [p - np.array([0.0, 0.0, home_amsl]) for p in path_amsl]
    terrain_doc = {
        "dem": dem.path, "dem_crs": dem.crs_name, "vertical": dem.vertical,
        "home_amsl_m": home_amsl, **tspec.to_doc(),
        "energy_m": energy, "climbed_m": climbed, "descended_m": descended,
        "plan_cost_m": plan.get("cost_m"), "legs": leg_docs,
        "lowest_clearance_m": min(d["clearance_m"] for d in leg_docs) if leg_docs else None,
    }
    return mi.Mission(items, origin, path_length(pts), budget, closed, sites_out, nav_rel,
                      footprints, spec, terrain_doc)


def _profile(model: TerrainModel, start: int, pts: np.ndarray, dem: Any) -> dict[str, Any]:
    """Distance along a leg's horizontal part vs terrain height vs flight height (AMSL):
    from the climb point (pts[start + 1]) to the point over the next site (pts[start + 2])."""
    a, b = pts[start + 1], pts[start + 2]
    n = PROFILE_SAMPLES
    t = np.linspace(0.0, 1.0, n)
    xy = a[None, :2] + (b[:2] - a[:2])[None] * t[:, None]
    ground = dem.height(xy, "a leg's profile")
    dist = np.hypot(*(b[:2] - a[:2])) * t
    return {"distance_m": np.round(dist, 2).tolist(),
            "terrain_amsl_m": np.round(ground, 2).tolist(),
            "flight_amsl_m": float(a[2])}
