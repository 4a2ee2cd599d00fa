"""Every artefact path of a survey run, in one place (ODM's ODM_Tree idea, STYLE.md).

    DIR/stages.json          the ledger: per stage its key (options + inputs), wall time
    DIR/model.json           the classifier (mound.classifier)
    DIR/classifier.json      its evaluation on sat.tst
    DIR/sites.json           the candidate sites (mound.sites v1), input of mound_plan
    DIR/plan.json            mound_plan's tour (mound.plan v1)
    DIR/mission.plan         the MAVLink mission (QGroundControl .plan), .waypoints, .geojson
    DIR/mission.json         the mission's summary (mound.mission v1)
    DIR/sites/<id>/          per visited site: sim/ (simulated flight), recon/ (mound_recon
                             reconstruct + verdict.json), dense/ (densify), rasters/
                             (GeoTIFFs), figures, site_result.json, log.txt; second/ the
                             same for a second, wider flight the first verdict advised
    DIR/second_look/         the missions of the second looks advised (mission.plan, ...,
                             mission.json, plan.json), for the aircraft to fly them
    DIR/photos_second/       their card sorted into the sites (--second-photos)
    DIR/summary.json         mound.survey v1
    DIR/report.html, report.md, report/ (the report's pictures)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mound.jsonio import load_json


@dataclass(frozen=True)
class RunTree:
    root: Path

    @property
    def ledger(self) -> Path:
        return self.root / "stages.json"

    @property
    def model(self) -> Path:
        return self.root / "model.json"

    @property
    def classifier_eval(self) -> Path:
        return self.root / "classifier.json"

    @property
    def sites(self) -> Path:
        return self.root / "sites.json"

    @property
    def plan(self) -> Path:
        return self.root / "plan.json"

    @property
    def mission_plan(self) -> Path:
        return self.root / "mission.plan"

    @property
    def mission_wpl(self) -> Path:
        return self.root / "mission.waypoints"

    @property
    def mission_geojson(self) -> Path:
        return self.root / "mission.geojson"

    def flight_file(self, name: str, flight: int | None) -> Path:
        """`name` (mission.plan, ...) of one flight of several: mission_2.plan; of the only
        flight: mission.plan."""
        from mound.uav.files import flight_path

        return flight_path(self.root / name, flight)

    @property
    def second_look(self) -> Path:
        """The second looks' missions (mission.plan, ... and mission.json), when the
        verdicts advised one."""
        return self.root / "second_look"

    @property
    def second_photos(self) -> Path:
        """The second card sorted into the second looks' sites (--second-photos)."""
        return self.root / "photos_second"

    @property
    def mission_summary(self) -> Path:
        return self.root / "mission.json"

    @property
    def photos(self) -> Path:
        """The photo card sorted into the sites (--photos): photos.json, <site id>/."""
        return self.root / "photos"

    @property
    def learn(self) -> Path:
        """Each flight's model, sites and plan (--learn): learn/flight_K/, learn.json."""
        return self.root / "learn"

    def final_sites(self, learned: bool) -> Path:
        """The sites with the p_mound of the final labels: the last learned model's with
        --learn, else sites.json."""
        return self.learn / "sites_final.json" if learned else self.sites

    def final_plan(self, learned: bool) -> Path:
        """The flights as flown: each re-planned flight with --learn, else plan.json."""
        return self.learn / "plan_flown.json" if learned else self.plan

    def site_dir(self, site_id: str) -> Path:
        return self.root / "sites" / site_id

    @property
    def summary(self) -> Path:
        return self.root / "summary.json"

    @property
    def report_html(self) -> Path:
        return self.root / "report.html"

    @property
    def report_md(self) -> Path:
        return self.root / "report.md"

    @property
    def report_dir(self) -> Path:
        return self.root / "report"


@dataclass(frozen=True)
class SiteTree:
    """The files of one visited site (inside DIR/sites/<id>/)."""

    root: Path

    @property
    def sim(self) -> Path:
        return self.root / "sim"

    @property
    def recon(self) -> Path:
        return self.root / "recon"

    @property
    def verdict(self) -> Path:
        return self.root / "recon" / "verdict.json"

    @property
    def result(self) -> Path:
        return self.root / "site_result.json"

    @property
    def log(self) -> Path:
        return self.root / "log.txt"

    @property
    def thumbnails(self) -> Path:
        return self.root / "thumbnails.png"

    @property
    def cloud_png(self) -> Path:
        return self.root / "cloud.png"

    @property
    def relief_png(self) -> Path:
        return self.root / "relief.png"

    @property
    def dense(self) -> Path:
        return self.root / "dense"

    @property
    def rasters(self) -> Path:
        return self.root / "rasters"

    @property
    def terrain_png(self) -> Path:
        return self.root / "terrain.png"

    @property
    def second(self) -> SiteTree:
        """The second look's files (a wider flight over a site the first left undecided)."""
        return SiteTree(self.root / "second")


def waiting_for_card(tree: RunTree) -> str | None:
    """A day on cards waiting for a battery's card: why (learn.json's `stopped`)."""
    path = tree.learn / "learn.json"
    if not path.is_file():
        return None
    doc = load_json(path)
    return (str(doc.get("stopped", "")) if isinstance(doc, dict)
            and doc.get("waiting_for_battery") is not None else None)
