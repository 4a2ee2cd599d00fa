"""Real terrain under every flight: site grounds, transit heights that clear the DEM, and
the climbs in the one budget (the planner's costs and the flown mission alike).

Heights (all from the DEM, metres above mean sea level, EGM96; see geometry/dem.py):
- A site's ground g_i: the median height of the ring from D/2 to D around its centre (D the
  scan's scale, the candidate's diameter): the ground around the candidate, the mound
  itself left out. Its scan flies the ScanSpec's pattern shifted up by g_i, so every scan
  waypoint is at the requested height above that site's ground.
- A node's reference height T_i: a site's g_i + the scan's transit height (above the site
  centre, where the planner's scan cost starts and ends); home's (and a path end's) ground,
  where the aircraft takes off and lands.
- A leg's transit height H_ij = max(T_i, T_j, highest terrain within `footprint_m` of the
  straight legs between the two sites (either direction: the last scan waypoint of one to
  the first of the other) + `clearance_m`). The aircraft climbs in place to H_ij before the
  leg and descends in place after it: the obstacle is cleared for the whole leg.
- Every scan waypoint and the straight line between consecutive ones clears the terrain
  (same footprint) by `scan_clearance_m`, or the site is refused by name.

Energy in metres of level flight (the one budget): a path costs its horizontal length plus
`climb_factor` per metre climbed and `descent_factor` per metre descended (defaults 3 and
2: climbing at 4 m/s and descending at 6 m/s take as long as 3 m and 2 m of cruise at
12 m/s, and a multicopter's power is close to constant). The planner's cost of a leg is
    c_ij = d_ij + (s_i + s_j) / 2 + climb * (H_ij - T_i) + descent * (H_ij - T_j)
with s_i the energy of the site's scan loop from and back to its reference point. It is
not symmetric when T_i != T_j, but its asymmetric part is (phi_j - phi_i) / 2 with the
potential phi = (climb - descent) T, which sums to zero round a closed tour: mound_plan
gets the symmetric part (`terrain.extra_m` of sites.json, added to the planar c_ij), and a
path home -> end pays the constant (phi_end - phi_home) / 2 (`terrain.path_offset_m`).
The mission flies the same heights, and its energy is at most the plan's cost (it cuts
corners from the last scan waypoint straight to the next site's first).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mound.errors import InputError
from mound.formats.mission import CLEARANCE_M, FACTOR, ClearanceSpec
from mound.formats.sites import Sites
from mound.geometry.dem import Dem
from mound.geometry.flight import ScanLeg, ScanSpec

TERRAIN_SCHEMA_VERSION = 1


def energy_m(points: np.ndarray, climb: float, descent: float) -> float:
    """Energy of flying the 3-D polyline `points` in metres of level flight."""
    p = np.asarray(points, dtype=float)
    if len(p) < 2:
        return 0.0
    d = np.diff(p, axis=0)
    dz = d[:, 2]
    return float(np.hypot(d[:, 0], d[:, 1]).sum() + climb * np.clip(dz, 0, None).sum()
                 + descent * np.clip(-dz, 0, None).sum())


def climb_descent_m(points: np.ndarray) -> tuple[float, float]:
    dz = np.diff(np.asarray(points, dtype=float)[:, 2])
    return float(np.clip(dz, 0, None).sum()), float(np.clip(-dz, 0, None).sum())


def site_loop(scan: ScanSpec, legs: list[ScanLeg] | None = None) -> np.ndarray:
    """A site's scan relative to its centre and ground, as the planner counts it: from the
    reference point above the centre (transit height) to the entry above the first
    waypoint, through every waypoint, back to the reference point."""
    legs = legs or scan.legs()
    path = scan.site_path(legs)
    ref = np.array([[0.0, 0.0, scan.transit_m(legs)]])
    return np.vstack([ref, path, ref])


def site_energy_m(scan: ScanSpec, spec: ClearanceSpec) -> float:
    """The terrain-mode scan cost s_i of every site (the loop's shape does not depend on
    the ground under it)."""
    return energy_m(site_loop(scan), spec.climb_factor, spec.descent_factor)


@dataclass
class TerrainNode:
    """A node of a tour: its position (ENU m) and, from a plan, the scan the plan costed."""

    id: str
    kind: str          # home, end, site
    x_m: float
    y_m: float
    scan_cost_m: float = 0.0


class TerrainModel:
    """Heights and leg costs of a set of nodes over a DEM (see the module docstring)."""

    def __init__(self, dem: Dem, spec: ClearanceSpec, scan: ScanSpec,
                 nodes: list[TerrainNode]) -> None:
        spec.check()
        self.dem, self.spec, self.scan, self.nodes = dem, spec, scan, nodes
        self.legs = scan.legs()
        self.transit = scan.transit_m(self.legs)
        xy = np.array([[n.x_m, n.y_m] for n in nodes], dtype=float).reshape(-1, 2)
        self.xy = xy
        is_site = np.array([n.kind == "site" for n in nodes])
        self.is_site = is_site
        self.ground = np.zeros(len(nodes))
        d = scan.site_diameter_m
        if is_site.any():
            self.ground[is_site] = site_grounds(dem, xy[is_site], d,
                                                [n.id for n in nodes if n.kind == "site"])
        if (~is_site).any():
            self.ground[~is_site] = dem.height(xy[~is_site], "home")
        self.ref = np.where(is_site, self.ground + self.transit, self.ground)
        first = self.legs[0].points_enu[0, :2]
        last = self.legs[-1].points_enu[-1, :2]
        # Where legs start and end: a site's last and first scan waypoint; home itself.
        self.exit_xy = np.where(is_site[:, None], xy + last, xy)
        self.entry_xy = np.where(is_site[:, None], xy + first, xy)
        self.scan_energy_m = site_energy_m(scan, spec)

    # ---- heights ------------------------------------------------------------------------
    def scan_points(self, i: int) -> np.ndarray:
        """Site i's scan waypoints in ENU with AMSL heights (the mission's, in order)."""
        c = np.array([self.xy[i, 0], self.xy[i, 1], self.ground[i]])
        return np.vstack([c + leg.points_enu for leg in self.legs])

    def check_scans(self, indices: list[int] | None = None) -> None:
        """InputError naming the first site whose scan comes closer to the terrain than
        scan_clearance_m."""
        idx = [i for i in (indices if indices is not None else range(len(self.nodes)))
               if self.is_site[i]]
        for i in idx:
            p = self.scan_points(i)
            a, b = p[:-1], p[1:]
            if len(a) == 0:
                a = b = p
            top, where = self.dem.corridor_max(a[:, :2], b[:, :2], self.spec.footprint_m,
                                               f"site {self.nodes[i].id}'s scan")
            low = np.minimum(a[:, 2], b[:, 2])
            gap = low - top
            k = int(np.argmin(gap))
            if gap[k] < self.spec.scan_clearance_m:
                raise InputError(
                    f"site {self.nodes[i].id}: its scan at {low[k]:.1f} m AMSL passes "
                    f"{gap[k]:.1f} m over the terrain at ENU ({where[k, 0]:.1f}, "
                    f"{where[k, 1]:.1f}) m ({top[k]:.1f} m), less than the scan clearance "
                    f"{self.spec.scan_clearance_m:g} m: fly it higher (--altitude)")

    def leg_heights(self, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
        """(H_ij, highest terrain near the leg, ENU point of it) for node pairs (arrays):
        symmetric in i and j."""
        i, j = np.asarray(i), np.asarray(j)
        what = f"leg {self.nodes[i[0]].id} -> {self.nodes[j[0]].id}" if len(i) else "a leg"
        t1, w1 = self.dem.corridor_max(self.exit_xy[i], self.entry_xy[j], self.spec.footprint_m,
                                       what)
        t2, w2 = self.dem.corridor_max(self.exit_xy[j], self.entry_xy[i], self.spec.footprint_m,
                                       what)
        top = np.maximum(t1, t2)
        where = np.where((t1 >= t2)[:, None], w1, w2)
        h = np.maximum(np.maximum(self.ref[i], self.ref[j]), top + self.spec.clearance_m)
        return h, top, where

    def height_matrix(self) -> np.ndarray:
        """H_ij for every pair (symmetric, zero diagonal)."""
        n = len(self.nodes)
        h = np.zeros((n, n))
        iu, ju = np.triu_indices(n, 1)
        if len(iu):
            hv, _, _ = self.leg_heights(iu, ju)
            h[iu, ju] = hv
            h[ju, iu] = hv
        return h

    def extra_matrix(self, h: np.ndarray | None = None) -> np.ndarray:
        """The symmetric part of the climbs' cost: (climb + descent) / 2 * (2 H - T_i - T_j)."""
        h = self.height_matrix() if h is None else h
        f = 0.5 * (self.spec.climb_factor + self.spec.descent_factor)
        e = f * (2 * h - self.ref[:, None] - self.ref[None, :])
        np.fill_diagonal(e, 0.0)
        return e

    def potential(self, k: int) -> float:
        return (self.spec.climb_factor - self.spec.descent_factor) * float(self.ref[k])

    def leg_cost(self, a: int, b: int, h: float) -> float:
        """The climbs' cost of the directed leg a -> b at transit height h."""
        return (self.spec.climb_factor * (h - self.ref[a])
                + self.spec.descent_factor * (h - self.ref[b]))

    def doc(self, extra: np.ndarray | None = None, closed: bool = True) -> dict[str, object]:
        """The `terrain` block of a sites.json (mound_plan reads extra_m and path_offset_m)."""
        extra = self.extra_matrix() if extra is None else extra
        end = len(self.nodes) - 1 if closed else 1
        offset = 0.0 if closed else 0.5 * (self.potential(end) - self.potential(0))
        return {
            "version": TERRAIN_SCHEMA_VERSION,
            "dem": self.dem.path, "dem_crs": self.dem.crs_name,
            "heights": "metres above mean sea level (EGM96)",
            **self.spec.to_doc(),
            "scan_energy_m": self.scan_energy_m,
            "nodes": [{"id": n.id, "ground_amsl_m": float(g), "reference_amsl_m": float(r)}
                      for n, g, r in zip(self.nodes, self.ground, self.ref, strict=True)],
            "extra_m": np.round(extra, 4).tolist(),
            "path_offset_m": offset,
        }


def site_grounds(dem: Dem, centres: np.ndarray, site_diameter_m: float,
                 ids: list[str]) -> np.ndarray:
    """The median DEM height of the ring D/2..D around each centre (the ground around a
    candidate of diameter D, the candidate itself left out)."""
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    step = max(1.0, min(dem.pixel_m) )
    r = np.arange(site_diameter_m / 2, site_diameter_m + 1e-9, step)
    out = np.empty(len(centres))
    for k, c in enumerate(centres):
        pts = []
        for rad in r:
            m = max(8, int(np.ceil(2 * np.pi * rad / step)))
            a = np.linspace(0, 2 * np.pi, m, endpoint=False)
            pts.append(np.column_stack([c[0] + rad * np.cos(a), c[1] + rad * np.sin(a)]))
        out[k] = float(np.median(dem.height(np.vstack(pts), f"site {ids[k]}'s ground")))
    return out


def sites_nodes(sites: Sites) -> tuple[list[TerrainNode], bool]:
    """The sites' nodes in mound_plan's order (home, the end of a path, the sites in file
    order) and whether the tour is closed."""
    nodes = [TerrainNode(sites.home.id, "home", sites.home.x_m, sites.home.y_m)]
    if not sites.closed:
        nodes.append(TerrainNode(sites.end.id, "end", sites.end.x_m, sites.end.y_m))
    nodes += [TerrainNode(s.id, "site", s.x_m, s.y_m) for s in sites.sites]
    return nodes, sites.closed


def open_dem(path: str, origin: Any, vertical: str | None, xy: np.ndarray,
             scan: ScanSpec, spec: ClearanceSpec) -> Dem:
    """The DEM window that every query about these nodes needs (the same window for the
    same nodes, so that the sites document and the mission compute equal heights)."""
    margin = 2 * scan.site_diameter_m + spec.footprint_m + 50.0
    return Dem.open(path, origin, vertical, around=xy, margin_m=margin)


def attach(sites: Sites, dem_path: str, spec: ClearanceSpec, vertical: str | None,
           origin: Any) -> Sites:
    """Adds the terrain to sites that have a `scan`: every site's scan cost
    becomes its scan loop's energy, the take-off and landing climbs move into the legs,
    and `terrain` carries the heights and the legs' climb costs. Refuses (InputError) a
    site whose scan cannot clear the terrain."""
    scan = sites.scan()
    if scan is None:
        raise InputError("--dem needs a scan pattern (--scan-pattern): the heights follow "
                         "the scan")
    nodes, closed = sites_nodes(sites)
    xy = np.array([[n.x_m, n.y_m] for n in nodes])
    dem = open_dem(dem_path, origin, vertical, xy, scan, spec)
    spec = replace(spec, vertical=dem.vertical)
    model = TerrainModel(dem, spec, scan, nodes)
    model.check_scans()
    return replace(sites.with_sites([replace(s, scan_cost_m=model.scan_energy_m)
                                      for s in sites.sites], terrain=model.doc(closed=closed)),
                   takeoff_landing_m=0.0)


def add_arguments(p: Any) -> None:
    """The terrain options shared by `mound field make`, `mound mission build` and the
    survey driver."""
    g = p.add_argument_group("terrain (a DEM under every flight)")
    g.add_argument("--dem", help="single-band GeoTIFF DEM/DSM, any CRS: scan heights above "
                   "each site's ground, transit legs clear of the terrain, climbs in the "
                   "budget (without it: heights above home, terrain not checked)")
    g.add_argument("--dem-vertical", choices=("ellipsoid", "egm96", "egm2008"),
                   help="what the DEM's heights are above (default: what its CRS says; "
                   "national orthometric heights: egm96)")
    g.add_argument("--clearance-m", type=CLEARANCE_M.arg(), default=ClearanceSpec.clearance_m,
                   help="transit legs above the highest terrain near them, m (default 30)")
    g.add_argument("--scan-clearance-m", type=CLEARANCE_M.arg(),
                   default=ClearanceSpec.scan_clearance_m,
                   help="scans above the terrain, m (default 10)")
    g.add_argument("--footprint-m", type=CLEARANCE_M.arg(), default=ClearanceSpec.footprint_m,
                   help="horizontal margin of every leg (GNSS error, airframe), m (default 10)")
    g.add_argument("--climb-factor", type=FACTOR.arg(), default=ClearanceSpec.climb_factor,
                   help="metres of level flight one metre climbed costs (default 3)")
    g.add_argument("--descent-factor", type=FACTOR.arg(), default=ClearanceSpec.descent_factor,
                   help="metres of level flight one metre descended costs (default 2)")


def spec_from_args(args: Any) -> ClearanceSpec:
    spec = ClearanceSpec(clearance_m=args.clearance_m, scan_clearance_m=args.scan_clearance_m,
                       footprint_m=args.footprint_m, climb_factor=args.climb_factor,
                       descent_factor=args.descent_factor)
    spec.check()
    return spec
