"""The dense cloud the learned verdict is trained on and judges, in one place: the grids
(`mound sim grid --dense`), the survey (`--dense-size`) and the docs' standalone path all
densify with these settings, and the models trained on those clouds record them
(`cloud_settings`), so that `mound_recon verdict` can refuse a cloud made otherwise."""

from __future__ import annotations

DENSE_MAX_IMAGE_SIZE = 320     # px: the depth maps' longer side
DENSE_RESOLUTION_M = 0.25      # m: the fused cloud's voxel
# The densify options a model's cloud_settings records (dense.json's `options` names).
DENSE_SETTINGS = ("max_image_size", "resolution_m")
DENSIFY_ARGS = ("--max-image-size", str(DENSE_MAX_IMAGE_SIZE),
                "--resolution-m", str(DENSE_RESOLUTION_M))

# Structure from motion. The simulated survey's sites (640 x 480, a known lens) keep the
# fast setting; photos from a real card get COLMAP's density of keypoints (SIFT's contrast
# threshold 0.01, 6,000 features per image): on real photos it matches or beats pycolmap's
# camera accuracy (docs/results.md, issue 58) at 2.6-5 x its speed.
SIM_MAX_FEATURES = 4000
CARD_RECON_ARGS = ("--contrast-threshold", "0.01", "--max-features", "6000")
