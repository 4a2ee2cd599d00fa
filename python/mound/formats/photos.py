"""A sorted photo card's sites (photos.json, mound.photos v1), typed once.

`mound photos sort` writes photos.json: every file of the card with its site or why it has
none, and per site (`CardSite`) its usable photos, the blurred ones, their median
sharpness, whether they are enough and the camera its reconstruction starts from.
`CardSummary` is what the survey's summary and report keep of it (`read`, each member
checked): the card, the files' counts by what became of them, the sites and the folders
the card's listing could not read.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mound.errors import InputError
from mound.jsonio import (
    JsonObject,
    as_object,
    check_doc,
    load_json,
    require_count,
    require_id,
    require_number,
    require_string,
    short_repr,
    string_list,
)

SCHEMA = "mound.photos"
VERSION = 1
SITE_STATUSES = ("ok", "too_few_photos")


@dataclass(frozen=True)
class CardSite:
    """A site's photos on the card: `photos` usable, `blurred` left out against the site's
    `median_sharpness`, `status` ok or too_few_photos, and the site's `camera` (where it
    comes from and its facts: mound.photos.sort.site_camera)."""

    photos: int
    blurred: int
    median_sharpness: float
    status: str
    camera: JsonObject

    def to_doc(self) -> JsonObject:
        return {"photos": self.photos, "blurred": self.blurred,
                "median_sharpness": self.median_sharpness, "status": self.status,
                "camera": self.camera}

    @classmethod
    def from_doc(cls, doc: object, where: str) -> CardSite:
        d = as_object(doc, where)
        status = require_string(d, "status", where)
        if status not in SITE_STATUSES:
            raise InputError(f"{where}.status: expected ok or too_few_photos, "
                             f"got {short_repr(status)}")
        return cls(require_count(d, "photos", where), require_count(d, "blurred", where),
                   require_number(d, "median_sharpness", where, lo=0.0),
                   status, dict(as_object(d.get("camera", {}), f"{where}.camera")))


@dataclass(frozen=True)
class CardSummary:
    """What a survey keeps of its sorted card: the card's folder, the files' `counts` by
    what became of them ("site" or the reason it has none), the `sites` by id, photos.json's
    path in the run (`file`) and the folders the card's listing could not read."""

    card: str
    counts: dict[str, int]
    sites: dict[str, CardSite]
    file: str
    skipped_folders: tuple[str, ...] = ()

    def to_doc(self) -> JsonObject:
        return {"card": self.card, "counts": dict(self.counts),
                "sites": {k: v.to_doc() for k, v in self.sites.items()}, "file": self.file,
                "skipped_folders": list(self.skipped_folders)}

    @classmethod
    def from_card(cls, doc: object, path: str | Path, file: str) -> CardSummary:
        """The summary of photos.json's document parsed from `path` (named `file` in the
        run); InputError naming the file and the member on any defect."""
        d = check_doc(doc, path, SCHEMA, VERSION)
        where = str(path)
        counts = as_object(d.get("counts"), f"{where}.counts")
        sites = as_object(d.get("sites"), f"{where}.sites")
        return cls(require_string(d, "card", where),
                   {k: require_count(counts, k, f"{where}.counts") for k in counts},
                   {require_id(k, f"{where}.sites"): CardSite.from_doc(v, f"{where}.sites.{k}")
                    for k, v in sites.items()},
                   file, tuple(string_list(d, "skipped_folders", where)))

    @classmethod
    def read(cls, path: str | Path, file: str) -> CardSummary:
        return cls.from_card(load_json(path), path, file)
