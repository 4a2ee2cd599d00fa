// What `mound scene score` keeps of a block's logits (python/mound/scene/score.py's
// run_block and peaks hold the definitions; tests hold the two equal): the calibrated
// p(mound) = 1 / (1 + exp(-(a logit + b))), its binary entropy in bits (the reward), both as
// float32 rasters of the block's core, and the core's local maxima of p over 3 x 3 cells.
//
// The block's logits are rows x cols cells: the core and `margin` cells around it, so that
// a maximum at the core's edge sees its neighbours (outside the block counts as -inf).
#pragma once

#include <cstdint>
#include <vector>

namespace mound::scene {

struct Calibration {
  double a = 1.0, b = 0.0;
};

struct BlockScores {
  std::vector<float> p, reward;  // core (rows - 2 margin) x (cols - 2 margin); `nodata` where
                                 // a cell has no logit
  // The local maxima in the core: a cell whose p is finite and no lower than any of its 8
  // neighbours' (non-finite ones count as -inf), in row-major order; rows and cols in the
  // block's cells (margin included).
  std::vector<int32_t> peak_row, peak_col;
  std::vector<double> peak_p, peak_logit;
  int64_t scored = 0;  // core cells with a p
  double p_sum = 0;    // their p, summed
};

// Throws InputError when the margin leaves no core.
BlockScores ScoreBlock(const std::vector<double>& logits, int rows, int cols, int margin,
                       const Calibration& calibration, float nodata);

}  // namespace mound::scene
