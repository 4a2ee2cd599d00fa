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
