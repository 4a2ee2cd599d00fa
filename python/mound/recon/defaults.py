"""The settings of the 3-D stage that Python chooses, in one place.

The C++ tools' own defaults are the settings for real photos and for the verdict:
`mound_recon reconstruct` extracts what the survey extracts from a card (6,000 SIFT
features at contrast 0.01, COLMAP's density), and `mound_recon densify` makes the clouds
the shipped verdict models were trained on (320 px depth maps, 0.25 m voxels: the models'
`cloud_settings`, which the survey passes on and `mound_recon verdict` checks). So the
tutorial, the standalone tools and the survey agree on a card; what differs is chosen here,
by name.
"""

from __future__ import annotations

# the candidate sets a verdict measures: formats.verdict.CANDIDATES
from mound.formats.verdict import CANDIDATES as CANDIDATES
from mound.recon.tool_options import ReconstructOptions

# The densify options a model's cloud_settings records (dense.json's `options` names).
DENSE_SETTINGS = ("max_image_size", "resolution_m")

# Structure from motion of the simulated sites (640 x 480 renders of a known lens): the fast
# setting, which the training grids and the survey's simulated flights share (its
# max_features replaced by --max-features). Real photos take the tool's defaults.
SIM_RECONSTRUCT = ReconstructOptions(max_features=4000, contrast_threshold=0.04)

# Cells of a site's GeoTIFFs (mound recon rasters, the survey): the sparse cloud holds ~1
# point per m², the dense one (0.25 m voxels) ~16.
SPARSE_CELL_M = 2.0
DENSE_CELL_M = 0.5
