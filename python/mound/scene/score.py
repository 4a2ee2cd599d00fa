"""Scoring a scene block by block: p(mound) and reward rasters and the candidate sites.

The output grid has cells of `cell` scene pixels (1, or the stride; the paper's features:
their coarse cell), north-up in the scene's CRS. The scene is read in blocks of
`block` x `block` output cells (rasterio windows) with the halo the features need, so
memory stays bounded whatever the scene's size; blocks run on a local thread pool or, with
a scheduler address, as Dask tasks on that cluster (each worker reads its own window).

Candidates are the local maxima of p (3 x 3 cells) over the whole scene: each block is
scored with an extra margin of one cell so that a maximum at a block's edge sees its
neighbours in the next block; the maxima of all blocks are then thinned greedily in
order of p (highest first, ties by position) so that no two lie closer
than `min_separation_m`. Block-wise and whole-scene scoring therefore give the same
candidates (and the same p up to the summed-area tables' rounding, ~1e-12).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import ndimage

from mound.classify.reward import binary_entropy_bits
from mound.errors import InputError
from mound.geojson import point_feature_doc
from mound.jsonio import JsonObject
from mound.scene import kernel
from mound.scene.features import FeatureSpec
from mound.scene.model import SceneModel
from mound.scene.raster import SceneInfo, read_window

if TYPE_CHECKING:
    from affine import Affine

NODATA = -9999.0


@dataclass(frozen=True)
class OutGrid:
    cell: int          # scene pixels per output cell
    rows: int
    cols: int
    res_m: float       # output cell size, m
    west: float
    north: float

    @classmethod
    def of(cls, scene: SceneInfo, model: SceneModel, stride_m: float | None) -> OutGrid:
        if stride_m is not None and not 0 < stride_m < 1e5:  # NaN too, before rounding
            raise InputError(f"--stride-m: must be > 0 m (below 100 km), got {stride_m}")
        stride = 1 if stride_m is None else max(1, round(stride_m / scene.res_m))
        cell = model.spec.cell_px(scene.res_m, stride)
        return cls(cell, math.ceil(scene.height / cell), math.ceil(scene.width / cell),
                   cell * scene.res_m, scene.west, scene.north)

    def centre(self, row: np.ndarray, col: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """CRS coordinates of the centres of output cells."""
        return (self.west + (col + 0.5) * self.res_m, self.north - (row + 0.5) * self.res_m)

    def transform(self) -> Affine:
        from rasterio.transform import from_origin

        return from_origin(self.west, self.north, self.res_m, self.res_m)


def read_block(scene: SceneInfo, bands: list[int], spec: FeatureSpec, cell: int,
               r0: int, c0: int, n: int, m: int) -> tuple[np.ndarray, int]:
    """The pixels (bands, rows, cols) that output cells [r0, r0 + n) x [c0, c0 + m) need,
    and the halo (pixels of context on each side of them)."""
    halo = spec.halo_px(scene.res_m, cell)
    return read_window(scene, bands, r0 * cell - halo, c0 * cell - halo, n * cell + 2 * halo,
                       m * cell + 2 * halo), halo


def features_block(scene: SceneInfo, bands: list[int], spec: FeatureSpec, cell: int,
                   r0: int, c0: int, n: int, m: int, engine: str = "native") -> np.ndarray:
    """Features (n * m, F) of output cells [r0, r0 + n) x [c0, c0 + m); multiscale ones by
    the compiled kernel unless engine is "numpy" (the reference)."""
    block, halo = read_block(scene, bands, spec, cell, r0, c0, n, m)
    if _native(spec, engine):
        return kernel.features(block, spec, scene.res_m, halo, cell, n, m)
    return spec.compute(block, scene.res_m, halo, cell, n, m)


def _native(spec: FeatureSpec, engine: str) -> bool:
    """Whether the compiled kernel computes these features (multiscale, engine native)."""
    if engine not in kernel.ENGINES:
        raise InputError(f"--engine: expected {' or '.join(kernel.ENGINES)}, got {engine!r}")
    return spec.kind == "multiscale" and engine == "native"


def keep_freed_blocks() -> None:
    """Asks glibc's malloc to keep freed block-sized buffers for the next block instead of
    handing them back to the system and faulting them in again, zeroed, per block (a fifth
    of the scoring process's CPU time went to page faults; measured on a 100 Mpx scene:
    system time 7.3 -> 4.5 s). Process-wide; a no-op off glibc."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        mallopt = libc.mallopt if libc is not None else None
    except (OSError, AttributeError):
        return
    if mallopt is not None:
        mallopt(-1, 1 << 30)  # M_TRIM_THRESHOLD: keep up to 1 GiB of free memory
        mallopt(-3, 1 << 26)  # M_MMAP_THRESHOLD: blocks below 64 MB from the heap


CHUNK_CELLS = 16_384  # output cells evaluated at once: the intermediates stay in cache


def score_block(scene: SceneInfo, bands: list[int], model: SceneModel, grid: OutGrid,
                r0: int, c0: int, nr: int, nc: int, margin: int,
                aoi: list[Any] | None = None) -> np.ndarray:
    """Logits of output cells [r0 - margin, r0 + nr + margin) x [c0 - margin, ...) in
    numpy, the definition and the reference (`--engine numpy`; with the native engine,
    run_block sends multiscale blocks to the kernel instead); NaN outside the scene, at
    nodata and outside the AOI."""
    n, m = nr + 2 * margin, nc + 2 * margin
    spec = model.spec
    if spec.kind == "multiscale":
        block, halo = read_block(scene, bands, spec, grid.cell, r0 - margin, c0 - margin, n, m)
        tables = spec.tables(block, scene.res_m, halo, grid.cell, m)
        del block
        logit = np.empty((n, m))
        step = max(1, CHUNK_CELLS // m)
        for k in range(0, n, step):
            k1 = min(n, k + step)
            logit[k:k1] = model.logit_fm(tables.rows(k, k1)).reshape(k1 - k, m)
    else:
        feats = features_block(scene, bands, spec, grid.cell, r0 - margin, c0 - margin, n, m,
                               "numpy")
        logit = model.logit(feats).reshape(n, m)
    if aoi is not None:
        logit[~_aoi_mask(aoi, grid, r0 - margin, c0 - margin, n, m)] = np.nan
    return logit


def _aoi_mask(polys: list[Any], grid: OutGrid, r0: int, c0: int, n: int, m: int
              ) -> np.ndarray:
    from rasterio.features import geometry_mask
    from rasterio.transform import from_origin

    tf = from_origin(grid.west + c0 * grid.res_m, grid.north - r0 * grid.res_m, grid.res_m,
                     grid.res_m)
    return geometry_mask(polys, out_shape=(n, m), transform=tf, invert=True, all_touched=False)


class AoiMissesScene(InputError):
    """The area of interest lies wholly outside the scene (valid input: a survey of several
    scenes skips that one and says so)."""


def aoi_in_scene(polys_lonlat: list[Any], scene: SceneInfo, where: str) -> list[Any]:
    """The AOI polygons as GeoJSON geometries in the scene's CRS; AoiMissesScene when they
    miss the scene, InputError when a position cannot be taken to its CRS."""
    from mound.scene.raster import transformer_to_scene

    tr = transformer_to_scene(scene)
    geoms = []
    w, s, e, n = scene.bounds()
    hit = False
    for poly in polys_lonlat:
        rings = []
        for ring in poly:
            lon = np.array([c[0] for c in ring])
            lat = np.array([c[1] for c in ring])
            x, y = tr.transform(lon, lat)
            x, y = np.asarray(x), np.asarray(y)
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
                raise InputError(f"{where}: a position cannot be taken to the scene's CRS")
            rings.append(list(zip(x.tolist(), y.tolist(), strict=True)))
            if x.max() > w and x.min() < e and y.max() > s and y.min() < n:
                hit = True
        geoms.append({"type": "Polygon", "coordinates": rings})
    if not hit:
        raise AoiMissesScene(f"{where}: the area of interest misses the scene {scene.path}")
    return geoms


Peaks = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # p, row, col, logit (1-D)


def peaks(p: np.ndarray, margin: int, r0: int, c0: int, logit: np.ndarray | None = None
          ) -> Peaks:
    """Local maxima (p, row, col, logit or NaN) of the core of a block scored with `margin`
    extra cells; row/col in the output grid. Arrays, not tuples: a 100 Mpx scene at stride 1 has
    millions of 3 x 3 maxima (as Python tuples they took a gigabyte)."""
    q = np.where(np.isfinite(p), p, -np.inf)
    # 3 x 3 local maxima; `thin` then enforces the separation (a disc footprint of the
    # separation's radius cost O(r^2) per cell: 60x slower at 30 m).
    mx = ndimage.maximum_filter(q, size=3, mode="constant", cval=-np.inf)
    core = np.zeros_like(q, dtype=bool)
    core[margin:q.shape[0] - margin, margin:q.shape[1] - margin] = True
    rr, cc = np.nonzero((q == mx) & np.isfinite(q) & core)
    return (p[rr, cc], (rr - margin + r0).astype(np.int64), (cc - margin + c0).astype(np.int64),
            logit[rr, cc] if logit is not None else np.full(len(rr), np.nan))


def thin(found: Peaks, grid: OutGrid, min_sep_m: float, limit: int
         ) -> list[tuple[float, int, int]]:
    """Greedy: highest p first (ties: lower row, then column), none within min_sep_m of one
    kept; at most `limit`."""
    pv, rows, cols = found[:3]
    return [(float(pv[k]), int(rows[k]), int(cols[k]))
            for k in thin_indices(found, grid, min_sep_m, limit)]


def thin_indices(found: Peaks, grid: OutGrid, min_sep_m: float, limit: int) -> list[int]:
    """`thin`, as indices into the peak arrays."""
    pv, rows, cols = found[:3]
    order = np.lexsort((cols, rows, -pv))
    sep = min_sep_m / grid.res_m
    size = max(sep, 1.0)
    buckets: dict[tuple[int, int], list[tuple[int, int]]] = {}
    kept: list[int] = []
    for k in order.tolist():
        if len(kept) >= limit:
            break
        r, c = int(rows[k]), int(cols[k])
        br, bc = int(r // size), int(c // size)
        near = False
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                for (qr, qc) in buckets.get((br + dr, bc + dc), ()):
                    if (qr - r) ** 2 + (qc - c) ** 2 < sep * sep:
                        near = True
                        break
        if not near:
            kept.append(k)
            buckets.setdefault((br, bc), []).append((r, c))
    return kept


def _concat(parts: list[Peaks]) -> Peaks:
    if not parts:
        return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return (np.concatenate([x[0] for x in parts]), np.concatenate([x[1] for x in parts]),
            np.concatenate([x[2] for x in parts]), np.concatenate([x[3] for x in parts]))


def block_origins(grid: OutGrid, block: int) -> list[tuple[int, int, int, int]]:
    return [(r, c, min(block, grid.rows - r), min(block, grid.cols - c))
            for r in range(0, grid.rows, block) for c in range(0, grid.cols, block)]


@dataclass
class BlockResult:
    r0: int
    c0: int
    p: np.ndarray              # calibrated p, float32, core only, NODATA where there is none
    reward: np.ndarray         # binary entropy of p, bits, float32, NODATA where p is
    scored: int                # core cells with a p
    p_sum: float               # their p, summed
    peaks: Peaks
    seconds: float
    logit: np.ndarray | None   # core only, float64 (NaN: none); when asked for


def run_block(scene: SceneInfo, bands: list[int], model: SceneModel, grid: OutGrid,
              r0: int, c0: int, nr: int, nc: int, margin: int,
              aoi: list[Any] | None, engine: str = "native", with_logits: bool = False
              ) -> BlockResult:
    """A block's rasters, local maxima and (with_logits) logits. Multiscale features with
    the native engine: all in the kernel (kernel.scores, the same numbers as below);
    otherwise from score_block's logits here (the definition)."""
    start = time.perf_counter()
    core = (slice(margin, margin + nr), slice(margin, margin + nc))
    n, m = nr + 2 * margin, nc + 2 * margin
    if _native(model.spec, engine):
        pixels, halo = read_block(scene, bands, model.spec, grid.cell, r0 - margin,
                                  c0 - margin, n, m)
        mask = None if aoi is None else _aoi_mask(aoi, grid, r0 - margin, c0 - margin, n, m)
        s = kernel.scores(pixels, model, scene.res_m, halo, grid.cell, n, m, margin, NODATA,
                          with_logits, mask)
        # copies: views would keep the whole reply's buffer alive with the scene's peaks
        found = (s.peak_p.copy(), s.peak_row.astype(np.int64) - margin + r0,
                 s.peak_col.astype(np.int64) - margin + c0, s.peak_logit.copy())
        return BlockResult(r0, c0, s.p, s.reward, s.scored, s.p_sum, found,
                           time.perf_counter() - start,
                           s.logits[core] if s.logits is not None else None)
    logit = score_block(scene, bands, model, grid, r0, c0, nr, nc, margin, aoi)
    p = model.calibrate(logit)
    pc = p[core]
    ok = np.isfinite(pc)
    h = np.where(ok, binary_entropy_bits(np.where(ok, pc, 0.0)), NODATA).astype(np.float32)
    return BlockResult(r0, c0, np.where(ok, pc, NODATA).astype(np.float32), h, int(ok.sum()),
                       float(pc[ok].sum()), peaks(p, margin, r0, c0, logit),
                       time.perf_counter() - start, logit[core])


def run_blocks(scene: SceneInfo, bands: list[int], model: SceneModel, grid: OutGrid,
               block: int, aoi: list[Any] | None = None,
               threads: int = 1, scheduler: str | None = None, engine: str = "native",
               with_logits: bool = False) -> Iterator[BlockResult]:
    """Every block's result, in completion order; at most 2 x workers blocks in flight."""
    margin = 1  # the 3 x 3 maxima at a block's edge see the next block's cells
    jobs = block_origins(grid, block)
    args = [(scene, bands, model, grid, r, c, nr, nc, margin, aoi, engine, with_logits)
            for r, c, nr, nc in jobs]
    if scheduler:
        yield from _run_dask(scheduler, args)
        return
    if threads <= 1:
        for a in args:
            yield run_block(*a)
        return
    with ThreadPoolExecutor(max_workers=threads) as pool:
        pending: list[Any] = []
        it = iter(args)
        for a in it:
            pending.append(pool.submit(run_block, *a))
            if len(pending) >= 2 * threads:
                break
        while pending:
            done = pending.pop(0)
            nxt = next(it, None)
            if nxt is not None:
                pending.append(pool.submit(run_block, *nxt))
            yield done.result()


def _run_dask(address: str, args: list[tuple[Any, ...]]) -> Iterator[BlockResult]:
    from distributed import Client, as_completed

    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError) as e:
        raise InputError(f"--scheduler: cannot reach {address} ({e})") from None
    try:
        width = max(2, 2 * sum(client.nthreads().values()))
        it = iter(args)
        futures = as_completed([client.submit(run_block, *a, pure=False)
                                for a in _take(it, width)])
        for fut in futures:
            res = fut.result()
            nxt = next(it, None)
            if nxt is not None:
                futures.add(client.submit(run_block, *nxt, pure=False))
            fut.release()
            yield res
    finally:
        client.close()


def _take(it: Iterator[Any], n: int) -> list[Any]:
    out = []
    for _ in range(n):
        nxt = next(it, None)
        if nxt is None:
            break
        out.append(nxt)
    return out


def logit_map(scene: SceneInfo, model: SceneModel, stride_m: float | None = None,
              block: int = 256, threads: int = 1, engine: str = "native"
              ) -> tuple[np.ndarray, OutGrid]:
    """The whole scene's logits in memory (training and evaluation on modest scenes)."""
    grid = OutGrid.of(scene, model, stride_m)
    bands = model.band_indices(scene)
    out = np.full((grid.rows, grid.cols), np.nan)
    for res in run_blocks(scene, bands, model, grid, block, threads=threads, engine=engine,
                          with_logits=True):
        assert res.logit is not None
        out[res.r0:res.r0 + res.logit.shape[0], res.c0:res.c0 + res.logit.shape[1]] = res.logit
    return out, grid


def candidates_of_map(p: np.ndarray, grid: OutGrid, min_sep_m: float, limit: int
                      ) -> list[tuple[float, int, int]]:
    """Candidates of an in-memory p map (the same rule as the block-wise scoring)."""
    return thin(peaks(p, 0, 0, 0), grid, min_sep_m, limit)



def _candidate_features(kept: list[tuple[float, int, int]], grid: OutGrid, scene: SceneInfo,
                        logits: dict[tuple[int, int], float]) -> list[dict[str, Any]]:
    from mound.scene.raster import transformer_from_scene

    if not kept:
        return []
    rows = np.array([r for _, r, _ in kept])
    cols = np.array([c for _, _, c in kept])
    x, y = grid.centre(rows, cols)
    lon, lat = transformer_from_scene(scene).transform(x, y)
    width = max(3, len(str(len(kept))))
    out = []
    for k, (p, r, c) in enumerate(kept):
        p = float(min(max(p, 0.0), 1.0))
        out.append({"type": "Feature", "id": f"c{k + 1:0{width}d}",
                    "geometry": {"type": "Point", "coordinates": [round(float(lon[k]), 8),
                                                                  round(float(lat[k]), 8)]},
                    "properties": {"id": f"c{k + 1:0{width}d}", "rank": k + 1,
                                   "p_mound": p, "reward": float(binary_entropy_bits(p)),
                                   "logit": logits[(r, c)],
                                   "x": float(x[k]), "y": float(y[k]), "row": r, "col": c,
                                   "scene": scene.path.name}})
    return out


def _timings(wall: float, block_s: list[float], px: int) -> JsonObject:
    return {"wall_s": wall, "blocks": len(block_s),
            "block_s_median": float(np.median(block_s)) if block_s else 0.0,
            "mpx_per_s": px / wall / 1e6 if wall > 0 else None}


def _raster_profile(scene: SceneInfo, grid: OutGrid) -> dict[str, object]:
    """The GeoTIFF profile (rasterio's, with its CRS and Affine) of p_mound.tif and
    reward.tif on the output grid."""
    return {"driver": "GTiff", "width": grid.cols, "height": grid.rows, "count": 1,
            "dtype": "float32", "crs": scene.crs(), "transform": grid.transform(),
            "nodata": NODATA, "tiled": True, "blockxsize": 256, "blockysize": 256,
            # ZSTD: as small as DEFLATE on these rasters, ~6 x faster to write (GDAL >= 2.3
            # reads it; the writes were a third of a 2-core run's time with DEFLATE); at
            # level 1 instead of GDAL's 9 a fifth faster again and as small (p's float32
            # mantissas hardly compress: 350 of 400 MB at either level on 100 Mpx)
            "compress": "zstd", "zstd_level": 1, "BIGTIFF": "IF_SAFER"}


def _no_position_scored(scene: SceneInfo, out: Any, model_path: str) -> None:
    """scene.json saying `status: failed` and why, then NoResultError."""
    from mound.errors import NoResultError
    from mound.jsonio import write_json

    write_json(out / "scene.json", {
        "schema": "mound.scene", "version": 1, "status": "failed",
        "reason": "no position of the scene could be scored (nodata, outside the AOI, or "
        "the scene smaller than the features' windows)",
        "scene": {"file": str(scene.path)}, "model": {"file": model_path}})
    raise NoResultError(f"{scene.path}: no position could be scored (nodata, the AOI, or a "
                        "scene smaller than the features' windows)")


def score_to_dir(scene: SceneInfo, model: SceneModel, out_dir: Any, *, model_path: str,
                 model_sha256: str, stride_m: float | None = None, limit: int = 20,
                 min_sep_m: float = 30.0, aoi: list[Any] | None = None,
                 aoi_path: str | None = None, home: tuple[float, float] | None = None,
                 block: int | None = None, threads: int = 1, scheduler: str | None = None,
                 progress: Callable[[int, int], None] | None = None,
                 engine: str = "native") -> dict[str, Any]:
    """Scores `scene` into out_dir: p_mound.tif, reward.tif (float32, NODATA where there is
    no score), candidates.geojson and scene.json, all staged and renamed into place
    together once every block is done."""
    from contextlib import ExitStack
    from pathlib import Path

    import rasterio
    from rasterio.windows import Window

    from mound.jsonio import json_text, write_all_atomic

    if not 0 <= min_sep_m < 1e5:
        raise InputError("--min-separation-m: must be >= 0 m")
    if not 1 <= limit <= 1_000_000:
        raise InputError("--candidates: must be 1 .. 1,000,000")
    start = time.perf_counter()
    bands = model.band_indices(scene)
    grid = OutGrid.of(scene, model, stride_m)
    if block is None:
        # ~1024 pixels a side: the halo the windows need (2 x 51 px at 1 m) adds 20 % to
        # what is read and summed, against 96 % with blocks of 256 pixels
        block = max(16, 1024 // grid.cell)
    if not 16 <= block <= 8192:
        raise InputError("--block: must be 16 .. 8192 cells")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out: {out} is a file, not a folder")
    out.mkdir(parents=True, exist_ok=True)
    profile = _raster_profile(scene, grid)
    found: list[Peaks] = []
    n_found = 0
    cells = valid = 0
    p_sum = 0.0
    block_s: list[float] = []
    from mound.jsonio import staged_file

    with ExitStack() as stack:
        p_tmp = stack.enter_context(staged_file(out / "p_mound.tif", ".tif"))
        r_tmp = stack.enter_context(staged_file(out / "reward.tif", ".tif"))
        p_ds = stack.enter_context(rasterio.open(p_tmp, "w", **profile))
        r_ds = stack.enter_context(rasterio.open(r_tmp, "w", **profile))
        p_ds.set_band_description(1, "p(mound), calibrated")
        r_ds.set_band_description(1, "reward: binary entropy of p(mound), bits")
        total = len(block_origins(grid, block))
        for done, res in enumerate(run_blocks(scene, bands, model, grid, block, aoi,
                                              threads, scheduler, engine), start=1):
            nr, nc = res.p.shape
            win = Window(res.c0, res.r0, nc, nr)
            p_ds.write(res.p, 1, window=win)
            r_ds.write(res.reward, 1, window=win)
            cells += res.p.size
            valid += res.scored
            p_sum += res.p_sum
            block_s.append(res.seconds)
            found.append(res.peaks)
            n_found += len(res.peaks[0])
            if progress:
                progress(done, total)
        p_ds.close()
        r_ds.close()
        if valid == 0:
            _no_position_scored(scene, out, model_path)
        allp = _concat(found)
        del found
        idx = thin_indices(allp, grid, min_sep_m, limit)
        kept = [(float(allp[0][k]), int(allp[1][k]), int(allp[2][k])) for k in idx]
        logits = {(int(allp[1][k]), int(allp[2][k])): float(allp[3][k]) for k in idx}
        feats = _candidate_features(kept, grid, scene, logits)
        if home is not None:  # the take-off point: the file is then a survey's --sites
            feats.insert(0, point_feature_doc(home, {"kind": "home", "id": "home"}, "home"))
        wall = time.perf_counter() - start
        px = scene.width * scene.height
        doc = {"schema": "mound.scene", "version": 1, "status": "ok",
               "scene": {"file": str(scene.path), "width": scene.width,
                         "height": scene.height, "bands_used": bands,
                         "resolution_m": scene.res_m, "crs": scene.crs().to_string()},
               "model": {"file": model_path, "sha256": model_sha256,
                         "features": model.spec.kind},
               "aoi": aoi_path, "grid": {"cell_px": grid.cell, "resolution_m": grid.res_m,
                                         "width": grid.cols, "height": grid.rows},
               "counts": {"cells": cells, "scored": valid, "nodata": cells - valid,
                          "local_maxima": n_found, "candidates": len(kept)},
               "p_mean": p_sum / valid if valid else None, "threshold": model.threshold,
               "min_separation_m": min_sep_m,
               "timings": {**_timings(wall, block_s, px), "threads": threads,
                           "scheduler": scheduler or "local threads", "engine": engine},
               "files": ["p_mound.tif", "reward.tif", "candidates.geojson"]}
        gj = {"type": "FeatureCollection", "name": f"candidates of {scene.path.name}",
              "features": feats}
        write_all_atomic([(out / "candidates.geojson", json_text(gj)),
                          (out / "scene.json", json_text(doc))])
    return doc
