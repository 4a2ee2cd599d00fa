"""The 3-D work of one visited site, as one task: images (simulated, or the UAV's photos),
`mound_recon reconstruct`, `mound_recon densify`, `mound_recon verdict` (on the dense
cloud with the dense cloud's model when there is one and it allows a verdict, else on the
sparse cloud), the site's GeoTIFFs and pictures for the report.

`process_site(job)` runs on a Dask worker (or in the driver's process); it never raises
for a failing site: the row it returns (mound.formats.site_row.SiteRow, also written to
DIR/sites/<id>/site_result.json, `mound.survey_site` v1) says `status: failed` and why,
and whether a rerun should try again (`retry`: a time-out, a crash, a killed tool) or not
(the input allowed no result).

A second card (--second-photos) changes the site's key but not its first look's
(`first_key`): when the row of the run before ended ok with the same first look, its
photos, reconstruction, dense cloud, verdict and GeoTIFFs are kept and only the second look
is done (the row says `first_look_reused`).
"""

from __future__ import annotations

import os
import socket
import time
import traceback
from dataclasses import dataclass, field, replace
from pathlib import Path

from mound import native
from mound.errors import (
    InputError,
    NoResultError,
    ToolError,
    ToolInputError,
    ToolNoResultError,
    ToolTimeout,
)
from mound.formats.recon import Recon
from mound.formats.site_row import SecondLookRecord, SiteRow
from mound.formats.sites import Site
from mound.formats.verdict import SecondLookAdvice, Verdict, VerdictFile
from mound.geometry.flight import DEFAULT_SITE_DIAMETER_M
from mound.geometry.geodesy import Origin
from mound.jsonio import JsonObject, read_json, write_json
from mound.photos.sort import MIN_PHOTOS
from mound.recon.tool_options import DensifyOptions, ReconstructOptions, VerdictOptions
from mound.sim.card import SiteGround
from mound.survey.tree import SiteTree

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")


@dataclass(frozen=True)
class SiteJob:
    """Everything one site's task needs; plain data, so that it travels to any worker."""

    site: Site                      # the site of sites.json (id, x_m, y_m, truth, ...)
    index: int                      # position in the field (seeds the simulation)
    run_root: str                   # absolute path of the run directory
    origin: Origin                  # the survey's WGS84 origin of x_m, y_m
    key: str                        # digest of everything below and the site row
    first_key: str = ""             # the same less the second card: the first look's
    run_id: str = ""                # tags the tools of this run (native.tagged)
    images_dir: str | None = None   # the UAV's photos; None: simulate the flight
    second_images_dir: str | None = None  # with photos: the second look's (--second-photos)
    image_size: tuple[int, int] = (640, 480)
    pattern: str = "raster"
    site_diameter_m: float = DEFAULT_SITE_DIAMETER_M
    sim_seed: int = 1
    recon: ReconstructOptions = field(default_factory=ReconstructOptions)
    dense: DensifyOptions | None = None  # None: no dense cloud
    verdict: VerdictOptions = field(default_factory=VerdictOptions)
    dense_model: str | None = None  # the dense cloud's verdict model file; None: built in
    threads: int = 1
    timeout_s: float = 1800.0
    figures: bool = True
    extra: dict[str, object] = field(default_factory=dict)
    terrain: SiteGround | None = None  # flown over a DEM: the site's ground on it

    @property
    def tree(self) -> SiteTree:
        return SiteTree(Path(self.run_root) / "sites" / self.site.id)


def _model_args(job: SiteJob) -> tuple[str, ...]:
    """mound_recon verdict's model for the dense cloud: the run's --verdict-model, or the
    tool's built-in one."""
    return ("--model", job.dense_model) if job.dense_model else ()


def _rel(path: Path, root: Path) -> str:
    try:
        return str(path.relative_to(root))
    except ValueError:
        return str(path)


def _simulate(job: SiteJob, row: SiteRow) -> tuple[Path, Path | None, str]:
    from mound.sim import site as sim
    from mound.sim.card import survey_site_spec

    spec, simulated = survey_site_spec(job.site, job.index, job.origin, job.sim_seed,
                                       job.image_size, job.pattern, job.site_diameter_m,
                                       job.terrain)
    row.extra["simulated"] = simulated
    t = job.tree
    doc = sim.simulate(spec, t.sim, threads=job.threads)
    simulated["images"] = doc["stats"]["images"]
    return t.sim / "images", t.sim / "camera.json", str(t.sim / "poses.json")


def _photos(job: SiteJob) -> tuple[Path, Path | None, str]:
    assert job.images_dir is not None
    folder = Path(job.images_dir)
    if not folder.is_dir():
        raise InputError(f"no photos of site {job.site.id} (no folder {folder}: none on "
                         "the card, or not sorted)")
    images = [p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES]
    if not images:
        raise InputError(f"{folder}: no images ({', '.join(IMAGE_SUFFIXES)})")
    if len(images) < MIN_PHOTOS:
        raise InputError(f"{folder}: {len(images)} photos, a reconstruction needs "
                         f"{MIN_PHOTOS}")
    camera = folder / "camera.json"
    poses = folder / "poses.json"
    return folder, camera if camera.is_file() else None, str(poses) if poses.is_file() else "exif"


def _recon_summary(recon_dir: Path) -> JsonObject:
    return Recon.read(recon_dir / "recon.json").summary()


def process_site(job: SiteJob) -> SiteRow:
    """Runs the site's work; returns its row (see the module text)."""
    with native.tagged(job.run_id):
        return _process_site(job)


def _process_site(job: SiteJob) -> SiteRow:
    t = job.tree
    root = Path(job.run_root)
    t.root.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    reused = _first_look_of_before(job)
    row = SiteRow(job.site.id, job.key, job.first_key, "failed",
                  "photos" if job.images_dir else "simulated",
                  f"{socket.gethostname()}:{os.getpid()}")
    timings = row.timings_s
    stage = "images"
    try:
        if reused is not None:  # the first look as the run before left it (second card)
            before, first = reused
            row.extra.update({k: before.extra[k] for k in FIRST_LOOK_EXTRA
                              if k in before.extra}, first_look_reused=True)
            row.verdict_cloud, row.files = before.verdict_cloud, dict(before.files)
            row.verdict, row.status = first, "ok"
            images, dense = root / row.files["images"], None
        else:
            t0 = time.perf_counter()
            if job.images_dir:
                images, camera, gps = _photos(job)
            else:
                images, camera, gps = _simulate(job, row)
                timings["simulate"] = time.perf_counter() - t0
            stage = "reconstruct"
            t0 = time.perf_counter()
            try:
                native.run_tool("mound_recon", _reconstruct_args(job, images, t, gps, camera),
                                job.timeout_s, log=t.log)
            finally:
                timings["reconstruct"] = time.perf_counter() - t0
                if (t.recon / "recon.json").is_file():
                    row.extra["recon"] = _recon_summary(t.recon)
            stage = "densify"
            dense = _densify(job, row)
            stage = "verdict"
            # The reference-free verdict judges the dense cloud when there is one (mound_recon
            # then scores it with the model learned on dense clouds); the paper's test
            # (--reference) the sparse cloud, as it always has.
            judged = dense if dense is not None and job.verdict.reference is None else None

            def verdict(*args: str) -> None:
                native.run_tool("mound_recon", ["verdict", str(t.recon), "--out", str(t.verdict),
                                                *args], job.timeout_s, log=t.log)

            t0 = time.perf_counter()
            if judged is not None:
                try:
                    verdict("--cloud", str(judged), *_model_args(job))
                # too few dense points on the site, or a cloud the model did not learn
                # (its settings: refused, exit 2): the sparse cloud is judged, and why not
                # the dense one is recorded and shown in the report
                except (ToolNoResultError, ToolInputError) as e:
                    row.extra["dense_verdict_error"] = _reason(e, t)
                    judged = None
            if judged is None:
                verdict(*job.verdict.argv())
            timings["verdict"] = time.perf_counter() - t0
            first = Verdict.read(t.verdict)
            row.verdict = first
            row.verdict_cloud = "sparse" if judged is None else "dense"
            row.status = "ok"
            row.files = {"images": _rel(images, root), "recon": _rel(t.recon, root),
                         "verdict": _rel(t.verdict, root)}
            if dense is not None:
                row.files["dense"] = _rel(t.dense, root)
        advice = first.second_look
        if advice is not None and advice.advised:
            stage = "second look"
            t0 = time.perf_counter()
            _second_look(job, row, advice, row.verdict_cloud == "dense")
            timings["second_look"] = time.perf_counter() - t0
        if reused is None:  # a kept first look keeps its GeoTIFFs
            _rasters(job, row, dense)
    except (InputError, NoResultError) as e:
        # The site's input allowed no result: the same input will fail the same way.
        row.status, row.reason, row.retry = "failed", f"{stage}: {_reason(e, t)}", False
    except (ToolTimeout, ToolError, OSError) as e:
        row.status, row.reason, row.retry = "failed", f"{stage}: {_reason(e, t)}", True
    except Exception as e:
        # A bug: the other sites go on, the row says what happened and the site's log keeps
        # the traceback; the survey ends with exit 1 once every site is done
        # (stages.sites3d.run_jobs), never a quiet "partial".
        row.status, row.reason, row.retry = "failed", f"{stage}: internal error {e!r}", True
        row.internal_error = True
        t.log.parent.mkdir(parents=True, exist_ok=True)
        with open(t.log, "a", encoding="utf-8") as log:
            log.write(f"internal error in stage {stage}:\n{traceback.format_exc()}")
    if job.figures and row.ok:
        t0 = time.perf_counter()
        try:
            row.files.update(site_figures(job, images, row))
        except Exception as e:  # the verdict stands; the report shows what is missing
            row.extra["figures_error"] = repr(e)
        timings["figures"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - start
    write_json(t.result, row.to_doc())
    return row


# What a site's row keeps of its first look when only the second look is done again
# (with its files and the cloud judged).
FIRST_LOOK_EXTRA = ("recon", "dense", "dense_error", "dense_verdict_error", "rasters",
                    "rasters_error")


def _first_look_of_before(job: SiteJob) -> tuple[SiteRow, Verdict] | None:
    """With a second card: the run before's row and first verdict of the site when that run
    ended ok with the same first look (first_key) and its first verdict is still there;
    else None (the whole site is done again)."""
    t = job.tree
    if not job.second_images_dir or not job.first_key or not t.result.is_file():
        return None
    try:
        before = SiteRow.read(t.result)
        first = VerdictFile.read(t.verdict)
    except (InputError, OSError):
        return None
    if (before.first_key != job.first_key or not before.ok or first.verdict is None
            or first.look != "first" or "images" not in before.files):
        return None
    return before, first.verdict


def _second_look(job: SiteJob, row: SiteRow, advice: SecondLookAdvice, dense: bool) -> None:
    """A site the first verdict left undecided (p_mound in the model's second_look band)
    flown again with a scan advice.scan_factor x as wide (simulated: the same site and
    seed, mound.sim.looks.wider; photos: the second card sorted into the site's folder,
    --second-photos, else the report asks for that flight), reconstructed,
    densified as the first and judged with `verdict --second-look FIRST_VERDICT`: both
    flights then decide the site (row.first_look keeps the first verdict). A second look
    that fails leaves the first verdict standing; row.second_look says why."""
    assert advice.scan_factor is not None  # the reader requires it of an advised look
    look = SecondLookRecord(True, advice.scan_factor, False)
    row.second_look = look
    if job.images_dir and not job.second_images_dir:
        look.reason = (f"{advice.extra.get('message', 'undecided')}: a second card of the "
                          "site "
                          "is needed (fly second_look/mission.plan, then run again with "
                          "--second-photos CARD)")
        return
    t = job.tree.second
    t.root.mkdir(parents=True, exist_ok=True)
    try:
        look.site_diameter_m = job.site_diameter_m * advice.scan_factor
        if job.images_dir:  # the second card, sorted into the site's folder
            images, camera, gps = _photos(replace(job, images_dir=job.second_images_dir))
            look.source = "photos"
        else:
            from mound.sim import site as sim
            from mound.sim.card import survey_site_spec
            from mound.sim.looks import wider

            spec, _ = survey_site_spec(job.site, job.index, job.origin, job.sim_seed,
                                       job.image_size, job.pattern, job.site_diameter_m,
                                       job.terrain)
            spec = wider(spec, advice.scan_factor)  # its site_diameter_m: look.site_diameter_m
            look.source = "simulated"
            sim.simulate(spec, t.sim, threads=job.threads)
            images, camera, gps = t.sim / "images", t.sim / "camera.json", str(
                t.sim / "poses.json")
        native.run_tool("mound_recon", _reconstruct_args(job, images, t, gps, camera),
                        job.timeout_s, log=t.log)
        args = ["verdict", str(t.recon), "--out", str(t.verdict), "--second-look",
                str(job.tree.verdict)]
        if dense:
            native.run_tool("mound_recon", _densify_args(job, t), job.timeout_s, log=t.log)
            args += ["--cloud", str(t.dense / "dense.ply"), *_model_args(job)]
        native.run_tool("mound_recon", args, job.timeout_s, log=t.log)
        second = Verdict.read(t.verdict)
    except (InputError, NoResultError, ToolTimeout, ToolError, OSError) as e:
        look.reason = _reason(e, t)
        return
    assert row.verdict is not None  # the first look's
    row.first_look = row.verdict
    # both flights' verdict; the coverage stays the first look's (its scan's)
    row.verdict = replace(second, coverage=row.verdict.coverage)
    look.flown, look.p_mound = True, second.p_mound
    look.verdict_file = _rel(t.verdict, Path(job.run_root))


def _reconstruct_args(job: SiteJob, images: Path, t: SiteTree, gps: str,
                      camera: Path | None) -> list[str]:
    """`mound_recon reconstruct` of `images` into t.recon, as the survey runs it."""
    args = ["reconstruct", str(images), "--out", str(t.recon), "--gps", gps,
            "--threads", str(job.threads), *job.recon.argv()]
    return args + (["--camera", str(camera)] if camera is not None else [])


def _densify_args(job: SiteJob, t: SiteTree) -> list[str]:
    """`mound_recon densify` of t.recon into t.dense, as the survey runs it."""
    return ["densify", str(t.recon), "--out", str(t.dense), "--threads", str(job.threads),
            *(job.dense.argv() if job.dense is not None else ())]


def _densify(job: SiteJob, row: SiteRow) -> Path | None:
    """The dense cloud (mound_recon densify, when job.dense), or None: not asked for,
    or densify failed (row.extra["dense_error"] says why; the verdict and the GeoTIFFs then use
    the sparse cloud)."""
    if job.dense is None:
        return None
    t = job.tree
    t0 = time.perf_counter()
    cloud = None
    try:
        native.run_tool("mound_recon", _densify_args(job, t), job.timeout_s, log=t.log)
        doc = read_json(t.dense / "dense.json", "mound.dense", 1)
        row.extra["dense"] = {"points": doc["points"], "options": doc["options"]}
        cloud = t.dense / "dense.ply"
    except (InputError, NoResultError, ToolError, ToolTimeout, OSError) as e:
        row.extra["dense_error"] = _reason(e, t)
    row.timings_s["densify"] = time.perf_counter() - t0
    return cloud


def _rasters(job: SiteJob, row: SiteRow, dense: Path | None) -> None:
    """The DSM, DTM, relief model, hillshade and orthophoto GeoTIFFs of a metric model in
    sites/ID/rasters/ (mound.recon.rasters, which refuses a model without a metric ENU
    frame): from the dense cloud at DENSE_CELL_M, else from the sparse one at
    SPARSE_CELL_M (mound.recon.defaults). The verdict stands without them; the row says
    why they are missing."""
    from mound.recon import rasters
    from mound.recon.defaults import DENSE_CELL_M, SPARSE_CELL_M

    t = job.tree
    cloud, cell = (dense, DENSE_CELL_M) if dense is not None else (None, SPARSE_CELL_M)
    t0 = time.perf_counter()
    try:
        doc = rasters.from_recon(t.recon, t.rasters, resolution_m=cell, cloud=cloud)
        row.extra["rasters"] = {"crs": doc["crs"], "resolution_m": doc["resolution_m"],
                                "width": doc["width"], "height": doc["height"],
                                "coverage": doc["coverage"],
                                "cloud": "dense" if cloud else "sparse"}
        row.files["rasters"] = _rel(t.rasters, Path(job.run_root))
    except NoResultError as e:  # the DSM is written, the DTM and LRM are not: say why
        row.extra["rasters_error"] = str(e)
        row.files["rasters"] = _rel(t.rasters, Path(job.run_root))
    except (InputError, OSError, ValueError) as e:
        row.extra["rasters_error"] = str(e)
    row.timings_s["rasters"] = time.perf_counter() - t0


def _reason(e: Exception, t: SiteTree) -> str:
    """One line: a tool's own reason from recon.json when it wrote one, else the error."""
    recon_json = t.recon / "recon.json"
    if isinstance(e, ToolError) and recon_json.is_file():
        try:
            recon = Recon.read(recon_json)
            if not recon.ok and recon.reason:
                return f"mound_recon: {recon.reason}"
        except InputError:
            pass
    if isinstance(e, ToolError):
        last = e.tail.strip().splitlines()[-1] if e.tail.strip() else ""
        return f"{e.tool} ({e.code}): {last}"
    return str(e)


def site_figures(job: SiteJob, images: Path, row: SiteRow) -> dict[str, str]:
    """The report's pictures of a site: a strip of its images, the cloud with cameras and
    the relief map with the verdict."""
    from mound.recon import figures as recon_figures
    from mound.survey import figures

    t = job.tree
    root = Path(job.run_root)
    figures.thumbnail_strip(images, t.thumbnails)
    recon_figures.cloud_and_cameras(t.recon, t.cloud_png, max_points=15000, dpi=60)
    figures.relief_map(t.recon, t.verdict, t.relief_png, title=f"{job.site.id}: "
                       f"{row.verdict.two_answer if row.verdict else '?'}")
    out = {"thumbnails": _rel(t.thumbnails, root), "cloud": _rel(t.cloud_png, root),
           "relief": _rel(t.relief_png, root)}
    rasters = row.extra.get("rasters")
    if isinstance(rasters, dict):
        figures.terrain_map(t.rasters, t.terrain_png, title=f"{job.site.id}: GeoTIFFs "
                            f"({rasters.get('cloud', 'sparse')} cloud), {rasters['crs']}")
        out["terrain"] = _rel(t.terrain_png, root)
    return out
