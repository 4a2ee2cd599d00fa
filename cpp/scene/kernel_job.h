// The scoring kernel's job file (mound.scene_kernel v1, written per block by
// python/mound/scene/native_kernel.py): a block of pixels, the cells to score, the features'
// geometry in pixels and the model. Loading validates every field and reports the first
// problem as an InputError naming it ("model.std[3]: must be > 0").
//
// {"schema": "mound.scene_kernel", "version": 1,
//  "block": "block.npy",                      // (bands, rows, cols) float32/64, NaN = nodata
//  "cells": {"halo": 52, "stride": 1, "rows": 1026, "cols": 1026},
//  "features": {"kind": "multiscale", "radii_px": [3, 6, 12, 24], "background_px": 48,
//               "red_band": 2, "nir_band": 3, "min_valid": 0.95},  // bands 0-based or null
//  "model": {"basis": "hinge", "clip": true, "mean": [...], "std": [...],
//            "weights": [...]}}              // F or 3F weights, then the bias
//
// The block's path is relative to the job file's folder.
#pragma once

#include <istream>
#include <ostream>
#include <string>

#include "scene/multiscale.h"

namespace mound::scene {

struct KernelJob {
  PixelBlock block;
  MultiscaleSpec spec;
  LinearModel model;
  CellGrid cells;
};

KernelJob LoadKernelJob(const std::string& path);
// `text` read from `path`; the block is resolved in `dir`.
KernelJob ParseKernelJob(const std::string& text, const std::string& path, const std::string& dir);

// `mound_scene --serve`: scores the requests on `in` one after another with one Scorer
// (its tables allocated once), until `in` ends (returns 0). A request is the job document
// on one line, with "want": "logits" | "features" | "scores" and its "block" an object
// {"dtype": "<f4" | "<f8", "shape": [bands, rows, cols]} saying how many raw little-endian
// bytes (C order, NaN = nodata) follow the line. "scores" (block_scores.h) also needs
// "scores": {"a", "b" (the calibration), "margin" (cells around the core), "nodata" (the
// rasters' value where a cell has no p), "logits" (true: the block's logits too)}.
// Each reply is one JSON line, {"status": "ok", "parts": [{"name", "dtype", "shape"}, ...],
// "bytes", "scored", "seconds", "simd"} (scores: "p_sum" too) followed by the parts' raw
// bytes in order — logits float64 (rows, cols); features float64 (rows, cols, F); scores
// p and reward float32 (the core), peak_row, peak_col int32, peak_p, peak_logit float64
// (the core's 3 x 3 maxima, in the block's cells), then logits when asked — or
// {"status": "error", "message": ...} (a bad field: the block is read past and the next
// request served). A line that is not JSON, a block layout that cannot be read or input
// that ends inside a block throws InputError (the stream cannot go on).
int ServeKernelJobs(std::istream& in, std::ostream& out, Simd simd);

}  // namespace mound::scene
