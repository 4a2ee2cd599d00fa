"""The compiled scoring kernel: a block's multiscale features and logits by `mound_scene
--serve` (cpp/scene/multiscale.h, kernel_job.h), one long-lived process per thread that
scores (native.checkout): the block's pixels go down its stdin, the result comes back on
its stdout, and the kernel keeps its tables between blocks.

The numpy code in features.py and model.py is the definition and the reference (`engine
numpy`); the kernel computes the same numbers (summed-area tables built in numpy's order,
no fused multiply-adds: features equal to ~1e-12, tested) without numpy's ~1,800 passes
over each block's intermediate arrays, which made scoring run at < 1 Mpx/s.

A call sends a `mound.scene_kernel` v1 job on one line and the block's raw bytes (float32
when that holds its values exactly, else float64; NaN = nodata), and reads the float64
result back. The kernel runs its loops with AVX2 where the CPU has it (the same bits as
without). The block's cells: output cell (k, l) is centred on block pixel (halo + stride // 2 +
k stride, ...), features.py's grid.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mound import native
from mound.jsonio import JsonObject
from mound.scene.features import MIN_VALID, FeatureSpec
from mound.scene.model import SceneModel

ENGINES = ("native", "numpy")


def _job(spec: FeatureSpec, res_m: float, halo: int, stride: int, n: int, m: int,
         model: SceneModel | None) -> JsonObject:
    labels = spec.band_labels
    radii, background = spec.window_px(res_m)
    feats: JsonObject = {
        "kind": "multiscale", "radii_px": radii, "background_px": background,
        "red_band": labels.index("red") if spec.has_ndvi else None,
        "nir_band": labels.index("nir") if spec.has_ndvi else None, "min_valid": MIN_VALID}
    nf = len(spec.names())
    mod: JsonObject
    if model is None:  # features only: a neutral model the reader accepts
        mod = {"basis": "none", "clip": False, "mean": [0.0] * nf, "std": [1.0] * nf,
               "weights": [0.0] * (nf + 1)}
    else:
        mod = {"basis": model.basis, "clip": model.clip,
               "mean": model.scaler.mean.tolist(), "std": model.scaler.std.tolist(),
               "weights": model.w.tolist()}
    return {"schema": "mound.scene_kernel", "version": 1,
            "cells": {"halo": halo, "stride": stride, "rows": n, "cols": m},
            "features": feats, "model": mod}


def _request(block: np.ndarray, job: JsonObject, want: str,
             extra: JsonObject | None = None, mask: np.ndarray | None = None
             ) -> tuple[Mapping[str, object], dict[str, np.ndarray]]:
    """One request to a `mound_scene --serve` of this thread: the reply and its parts.
    `mask` (the job's cells, True: scored) travels after the pixels."""
    if block.dtype == np.float32:
        data = np.ascontiguousarray(block)
    else:
        b32 = block.astype(np.float32)
        exact = np.array_equal(b32.astype(np.float64), block, equal_nan=True)
        data = b32 if exact else np.ascontiguousarray(block, np.float64)
    layout: JsonObject = {"dtype": data.dtype.str, "shape": list(data.shape)}
    payload = [data.data.cast("B")]
    if mask is not None:
        layout["cell_mask"] = int(mask.size)
        payload.append(np.ascontiguousarray(mask, np.uint8).data.cast("B"))
    head: JsonObject = {**job, "want": want, **(extra or {}), "block": layout}
    with native.checkout("mound_scene", ["--serve"]) as server:
        reply, raw = server.request(head, *payload)
    parts: dict[str, np.ndarray] = {}
    at = 0
    for part in native.tool_objects(reply, "parts", "mound_scene"):
        dtype = np.dtype(str(part.get("dtype")))
        shape = part.get("shape")
        if not isinstance(shape, list) or not all(isinstance(n, int) for n in shape):
            raise native.ToolError("mound_scene", native.EXIT_INTERNAL,
                                   f"a reply's part shape is {shape!r:.40}")
        count = int(np.prod(shape, dtype=np.int64))
        parts[str(part.get("name"))] = np.frombuffer(raw, dtype, count, at).reshape(shape)
        at += count * dtype.itemsize
    return reply, parts


def _run(block: np.ndarray, job: JsonObject, want: str) -> np.ndarray:
    return _request(block, job, want)[1][want]


@dataclass
class Scores:
    """What scoring keeps of a block (block_scores.h; score.run_block is the definition):
    float32 p and reward of the core (`nodata` where a cell has none), its 3 x 3 maxima of
    p (rows and columns in the block's cells, margin included), and the block's logits when
    asked for."""
    p: np.ndarray
    reward: np.ndarray
    peak_row: np.ndarray
    peak_col: np.ndarray
    peak_p: np.ndarray
    peak_logit: np.ndarray
    scored: int
    p_sum: float
    logits: np.ndarray | None


def scores(block: np.ndarray, model: SceneModel, res_m: float, halo: int, stride: int,
           n: int, m: int, margin: int, nodata: float, with_logits: bool = False,
           mask: np.ndarray | None = None) -> Scores:
    """The block's logits, calibrated and reduced in the kernel (block_scores.h); cells
    where `mask` (n, m) is False have none (outside an area of interest)."""
    job = _job(model.spec, res_m, halo, stride, n, m, model)
    extra: JsonObject = {"scores": {
        "a": model.calibration["a"], "b": model.calibration["b"], "margin": margin,
        "nodata": nodata, "logits": with_logits}}
    reply, parts = _request(block, job, "scores", extra, mask)
    return Scores(parts["p"], parts["reward"], parts["peak_row"], parts["peak_col"],
                  parts["peak_p"], parts["peak_logit"],
                  int(native.tool_number(reply, "scored", "mound_scene")),
                  native.tool_number(reply, "p_sum", "mound_scene"), parts.get("logits"))


def logits(block: np.ndarray, model: SceneModel, res_m: float, halo: int, stride: int,
           n: int, m: int) -> np.ndarray:
    """Uncalibrated logits (n, m) of the block's cells; NaN where a cell has none."""
    return _run(block, _job(model.spec, res_m, halo, stride, n, m, model), "logits")


def features(block: np.ndarray, spec: FeatureSpec, res_m: float, halo: int, stride: int,
             n: int, m: int) -> np.ndarray:
    """Features (n * m, F) of the block's cells, as FeatureSpec.compute gives them."""
    f = _run(block, _job(spec, res_m, halo, stride, n, m, None), "features")
    return f.reshape(n * m, -1)
