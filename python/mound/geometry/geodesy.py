"""WGS84 geodesy: geodetic <-> ECEF <-> local ENU, exact formulas (no flat-earth shortcut).

Geodetic (lat, lon in degrees, h in metres above the ellipsoid) to ECEF is closed form.
ECEF to geodetic iterates Bowring's latitude update with the height computed as
h = p cos(lat) + z sin(lat) - a sqrt(1 - e^2 sin^2 lat), which is stable at every latitude;
it converges to machine precision in a handful of steps. ENU is the local tangent frame
at an origin (x east, y north, z up), so the conversion is exact at any distance (the
round trip and the comparison with PROJ in the tests agree to well under a millimetre at
tens of kilometres).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mound.errors import InputError
from mound.jsonio import require_number

A = 6378137.0                  # WGS84 semi-major axis, m
F = 1 / 298.257223563          # flattening
E2 = F * (2 - F)               # first eccentricity squared


@dataclass(frozen=True)
class Origin:
    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0  # ellipsoidal (or MSL: used only as the ENU frame's height datum)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.lat_deg) and -90 <= self.lat_deg <= 90):
            raise InputError(f"origin: latitude must be in [-90, 90], got {self.lat_deg}")
        if not (np.isfinite(self.lon_deg) and -180 <= self.lon_deg <= 180):
            raise InputError(f"origin: longitude must be in [-180, 180], got {self.lon_deg}")
        if not np.isfinite(self.alt_m):
            raise InputError("origin: altitude must be finite")

    @classmethod
    def from_doc(cls, doc: object, where: str = "origin") -> Origin:
        if not isinstance(doc, dict):
            raise InputError(f"{where}: expected an object with lat, lon (and alt_m)")
        return cls(require_number(doc, "lat", where, lo=-90, hi=90),
                   require_number(doc, "lon", where, lo=-180, hi=180),
                   require_number(doc, "alt_m", where, lo=-1e5, hi=1e5, default=0.0))

    @classmethod
    def parse(cls, text: str) -> Origin:
        """'LAT,LON' or 'LAT,LON,ALT' (degrees, metres)."""
        try:
            parts = [float(p) for p in text.split(",")]
        except ValueError as e:
            raise InputError(f"--origin: expected LAT,LON[,ALT], got {text!r}") from e
        if len(parts) not in (2, 3):
            raise InputError(f"--origin: expected LAT,LON[,ALT], got {text!r}")
        return cls(*parts)

    def to_doc(self) -> dict[str, float]:
        return {"lat": self.lat_deg, "lon": self.lon_deg, "alt_m": self.alt_m}


def geodetic_to_ecef(lat_deg: np.ndarray, lon_deg: np.ndarray, h_m: np.ndarray) -> np.ndarray:
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    n = A / np.sqrt(1 - E2 * np.sin(lat) ** 2)
    return np.stack([(n + h_m) * np.cos(lat) * np.cos(lon), (n + h_m) * np.cos(lat) * np.sin(lon),
                     (n * (1 - E2) + h_m) * np.sin(lat)], axis=-1)


def ecef_to_geodetic(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1 - E2))
    for _ in range(8):
        s = np.sin(lat)
        n = A / np.sqrt(1 - E2 * s * s)
        h = p * np.cos(lat) + z * s - A * np.sqrt(1 - E2 * s * s)
        lat = np.arctan2(z, p * (1 - E2 * n / (n + h)))
    s = np.sin(lat)
    h = p * np.cos(lat) + z * s - A * np.sqrt(1 - E2 * s * s)
    return np.degrees(lat), np.degrees(lon), h


def _enu_rotation(origin: Origin) -> np.ndarray:
    """Rows: east, north, up unit vectors in ECEF at the origin."""
    lat, lon = np.radians(origin.lat_deg), np.radians(origin.lon_deg)
    return np.array([
        [-np.sin(lon), np.cos(lon), 0.0],
        [-np.sin(lat) * np.cos(lon), -np.sin(lat) * np.sin(lon), np.cos(lat)],
        [np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)],
    ])


def enu_to_geodetic(origin: Origin, enu: np.ndarray) -> np.ndarray:
    """(n, 3) ENU metres -> (n, 3) lat deg, lon deg, height m (on the origin's datum)."""
    enu = np.atleast_2d(np.asarray(enu, dtype=float))
    o = geodetic_to_ecef(np.array(origin.lat_deg), np.array(origin.lon_deg),
                         np.array(origin.alt_m))
    lat, lon, h = ecef_to_geodetic(o + enu @ _enu_rotation(origin))
    return np.stack([lat, lon, h], axis=-1)


def geodetic_to_enu(origin: Origin, llh: np.ndarray) -> np.ndarray:
    """(n, 3) lat deg, lon deg, height m -> (n, 3) ENU metres."""
    llh = np.atleast_2d(np.asarray(llh, dtype=float))
    o = geodetic_to_ecef(np.array(origin.lat_deg), np.array(origin.lon_deg),
                         np.array(origin.alt_m))
    d = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2]) - o
    return d @ _enu_rotation(origin).T
