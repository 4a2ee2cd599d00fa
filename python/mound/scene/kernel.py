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

from typing import Any

import numpy as np

from mound import native
from mound.scene.features import MIN_VALID, FeatureSpec
from mound.scene.model import SceneModel

ENGINES = ("native", "numpy")


def _job(spec: FeatureSpec, res_m: float, halo: int, stride: int, n: int, m: int,
         model: SceneModel | None) -> dict[str, Any]:
    labels = spec.band_labels
    radii, background = spec.window_px(res_m)
    feats = {"kind": "multiscale", "radii_px": radii, "background_px": background,
             "red_band": labels.index("red") if spec.has_ndvi else None,
             "nir_band": labels.index("nir") if spec.has_ndvi else None,
             "min_valid": MIN_VALID}
    nf = len(spec.names())
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


def _run(block: np.ndarray, job: dict[str, Any], want: str) -> np.ndarray:
    if block.dtype == np.float32:
        data = np.ascontiguousarray(block)
    else:
        b32 = block.astype(np.float32)
        exact = np.array_equal(b32.astype(np.float64), block, equal_nan=True)
        data = b32 if exact else np.ascontiguousarray(block, np.float64)
    head = {**job, "want": want,
            "block": {"dtype": data.dtype.str, "shape": list(data.shape)}}
    with native.checkout("mound_scene", ["--serve"]) as server:
        reply, raw = server.request(head, data.data.cast("B"))
    return np.frombuffer(raw, dtype="<f8").reshape(reply["shape"])


def logits(block: np.ndarray, model: SceneModel, res_m: float, halo: int, stride: int,
           n: int, m: int) -> np.ndarray:
    """Uncalibrated logits (n, m) of the block's cells; NaN where a cell has none."""
    return _run(block, _job(model.spec, res_m, halo, stride, n, m, model), "logits")


def features(block: np.ndarray, spec: FeatureSpec, res_m: float, halo: int, stride: int,
             n: int, m: int) -> np.ndarray:
    """Features (n * m, F) of the block's cells, as FeatureSpec.compute gives them."""
    f = _run(block, _job(spec, res_m, halo, stride, n, m, None), "features")
    return f.reshape(n * m, -1)
