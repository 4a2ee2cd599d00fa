"""mound.recon v1 (`mound_recon reconstruct`'s recon.json), as Python reads it.

`Recon.read(path)` validates what the survey, the rasters, the map and the figures use —
the status (a failed reconstruction says why and has no model), the frame and scale, the
WGS84 origin and what its heights are above, the camera, each image's pose
(`cam_from_world`, OpenCV axes) and centre, the counts — with an InputError naming the file
and the field. The rest (timings, the GPS fit, the bundle adjustments) stays in the file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mound.errors import InputError
from mound.geometry.camera import Camera, Pose
from mound.geometry.geodesy import Origin
from mound.jsonio import (
    JsonObject,
    as_object,
    check_doc,
    load_json,
    optional_number,
    optional_string,
    short_repr,
)

SCHEMA = "mound.recon"
VERSION = 1


def _matrix(v: object, shape: tuple[int, ...], where: str) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape != shape or not np.isfinite(a).all():
        raise InputError(f"{where}: expected {' x '.join(map(str, shape))} finite numbers, "
                         f"got {short_repr(v)}")
    return a


@dataclass(frozen=True)
class ReconImage:
    """An image of the model: its file, whether it was registered, and then its pose
    (cam_from_world) and centre (the model's frame)."""

    file: str
    registered: bool
    cam_from_world: Pose | None = None
    centre: tuple[float, float, float] | None = None

    @classmethod
    def from_doc(cls, doc: object, where: str) -> ReconImage:
        d = as_object(doc, where)
        name = d.get("file", "")
        registered = d.get("registered", False)
        if not isinstance(name, str) or not isinstance(registered, bool):
            raise InputError(f"{where}: file, registered: expected a string and true or false")
        if not registered:
            return cls(name, False)
        T = as_object(d.get("cam_from_world"), f"{where}.cam_from_world")
        c = _matrix(d.get("centre"), (3,), f"{where}.centre")
        return cls(name, True, Pose(_matrix(T.get("R"), (3, 3), f"{where}.cam_from_world.R"),
                                    _matrix(T.get("t"), (3,), f"{where}.cam_from_world.t")),
                   (float(c[0]), float(c[1]), float(c[2])))


@dataclass(frozen=True)
class Recon:
    """A reconstruction: `status` ok or failed (then `reason`); the model's frame (enu:
    georeferenced, metres east, north, up of `origin`) and scale (metric), what the
    origin's heights are above (`alt_datum`; None in files made before 2026-11-29) and
    where the GPS came from (`gps_source`), the camera, the images, the points and the
    reprojection error (px)."""

    path: str
    status: str
    reason: str = ""
    frame: str | None = None
    scale: str | None = None
    origin: Origin | None = None
    alt_datum: str | None = None
    gps_source: str | None = None
    images_dir: str | None = None
    camera: Camera | None = None
    images: tuple[ReconImage, ...] = ()
    points: int | None = None
    reprojection_rmse_px: float | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def poses(self) -> list[tuple[str, Pose, np.ndarray]]:
        """Each registered image's file, cam_from_world and centre (the model's frame)."""
        return [(im.file, im.cam_from_world, np.array(im.centre, dtype=float))
                for im in self.images
                if im.cam_from_world is not None and im.centre is not None]

    def summary(self) -> JsonObject:
        """What a site's row keeps of it (mound.survey_site's `recon`)."""
        return {"status": self.status, "frame": self.frame,
                "registered": len(self.poses()), "images": len(self.images),
                "points": self.points, "reprojection_rmse_px": self.reprojection_rmse_px,
                "reason": self.reason or None}

    @classmethod
    def from_doc(cls, doc: object, path: str | Path) -> Recon:
        d = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        status = d.get("status")
        if status not in ("ok", "failed"):
            raise InputError(f"{where}: status: expected ok or failed, got {short_repr(status)}")
        reason = optional_string(d, "reason", where) or ""
        origin_doc = d.get("origin")
        origin = None if origin_doc is None else Origin.from_doc(origin_doc, f"{where}: origin")
        alt_datum = None if origin_doc is None else optional_string(
            origin_doc, "alt_datum", f"{where}: origin")
        inputs = as_object(d.get("inputs") or {}, f"{where}: inputs")
        camera = None
        if d.get("camera") is not None:
            try:
                camera = Camera.from_doc(as_object(d["camera"], f"{where}: camera"))
            except (KeyError, TypeError, ValueError, IndexError, OverflowError) as err:
                raise InputError(f"{where}: camera: {err!r}") from err
        images = d.get("images", [])
        if not isinstance(images, list):
            raise InputError(f"{where}: images: expected a list")
        points = optional_number(d, "points", where, lo=0)
        return cls(where, str(status), reason, optional_string(d, "frame", where),
                   optional_string(d, "scale", where), origin, alt_datum,
                   optional_string(inputs, "gps_source", f"{where}: inputs"),
                   optional_string(d, "images_dir", where), camera,
                   tuple(ReconImage.from_doc(im, f"{where}: images[{k}]")
                         for k, im in enumerate(images)),
                   None if points is None else int(points),
                   optional_number(d, "reprojection_rmse_px", where, lo=0))

    @classmethod
    def read(cls, path: str | Path) -> Recon:
        return cls.from_doc(load_json(path), path)
