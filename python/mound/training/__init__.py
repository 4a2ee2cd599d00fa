"""The verdict's learning: grids of simulated sites (mound sim grid) measured by
mound_recon, a verdict model fitted on some and judged on others, its bound and its
second look. Above the simulator (sim) and the classifier (classify); the 3-D stage
(recon) applies the model it writes and knows nothing of how it was learned."""
