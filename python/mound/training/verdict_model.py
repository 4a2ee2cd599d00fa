"""The verdict model (`mound.verdict_model` v1): learned on one grid of simulated sites
(`mound sim grid`), judged on another.

Model: the paper's own tool, a logistic regression (eqs. (2)-(3), mound.classify.logistic)
on the standardised detector features that `mound_recon verdict` writes for each judged
rise of a site (measurements.judged_rises[].features: the most prominent rises, since a
scan of real ground holds natural rises, often larger than the tumulus; the names and
their order are the detector's, VerdictFeatureNames() in cpp/terrain), on a linear or
hinge basis, or the hinge basis with the products of every two of the rise's form and place
features (`hinge_products`, PRODUCT_FEATURES). A rise is a positive when it is the
tumulus's own, a negative when it lies
clear of any tumulus, and left out of the fit when it overlaps one otherwise
(`rise_labels`); the fit's loss is the rises' logistic loss, mixed with a multiple-instance
one over the sites' bags of rises (MIL_MIXES: the site's decision is its highest rise's).
A site's score is its highest rise's; that score is Platt-calibrated on the sites (folded into the
weights: the file stays one logistic regression and a max). Sites without a rise get
`p_no_rise`, the share of mounds among the training sites without one (Laplace-smoothed).
Basis, L2 penalty and that mix are chosen by 5-fold cross-validation over sites (the sites' log loss
after calibration). `z_clip` c bounds each standardised feature to [-c, c] before the
basis (c = 3, Z_CLIPS): a hinge is linear beyond the data, a product grows as the square,
and a rise whose feature lies far outside the training range (a torn cloud's, a real
site's) would otherwise score on an extrapolation. The chosen model's out-of-fold scores
are then taken over CV_REPEATS splits of the sites into folds (the first the selection's):
the Platt calibration is fitted on all of them, then a beta calibration of the Platt p
(the file's "calibration", `_calibrated`: the site's highest score is not logistic in the
truth), and the threshold is the lowest p >= 0.5 whose out-of-fold false-alarm rate over
them is <= 1 % — one split's rate rests on the three or four highest of some 360
negatives and moves with the split by several hundredths.

Evaluation on a held-out grid (other seeds: other sites, sun and lens): accuracy, false
alarms and missed detections per class, kind and profile; reliability table, Brier score
and ECE; the goal's subsets (mounds >= 2 m high and >= 15 m across; no-mound sites); the
old hand-set rule (height >= 1 m, base >= 8 m, roundness >= 0.6, dome R^2 >= 0.6) on the
same sites; and the detection limit, the detection rate over height x diameter.

This module is the verdict model's interface; the work is in verdict_data (grids, labels),
verdict_fit (basis, fit, calibration, threshold, `train`, `probability`), verdict_second
(the second look's rule), verdict_blocks (the model file's other blocks: the reasons'
thresholds, the terrain domain), verdict_eval (`evaluate`) and verdict_figures.
"""

from __future__ import annotations

from mound.formats.verdict import Rise, rises_of
from mound.recon.grid_site import GridSite, SiteTruth, sites_of
from mound.recon.model_file import VerdictModel
from mound.sim.looks import SECOND_LOOK_FACTOR
from mound.training.verdict_blocks import terrain_domain
from mound.training.verdict_data import (
    CLEAR_OF_GROUND,
    MAX_FA,
    feature_names_of,
    grid_cloud,
    grid_label,
    load_grid,
    rise_labels,
    site_terrain,
    stands_clear,
)
from mound.training.verdict_eval import evaluate, paper_agreement
from mound.training.verdict_figures import detection_figure, figure
from mound.training.verdict_fit import (
    BASES,
    CV_REPEATS,
    MIL_MIXES,
    MIL_TAU,
    PRODUCT_CLIP,
    SCHEMA,
    VERSION,
    probability,
    product_pairs,
    train,
)
from mound.training.verdict_second import SECOND_LOOK_FOLDS, second_look_p

__all__ = [
    "BASES", "CLEAR_OF_GROUND", "CV_REPEATS", "GridSite", "MAX_FA", "MIL_MIXES", "MIL_TAU",
    "PRODUCT_CLIP", "Rise", "SiteTruth", "VerdictModel", "rises_of", "sites_of",
    "SCHEMA", "SECOND_LOOK_FACTOR", "SECOND_LOOK_FOLDS", "VERSION", "detection_figure",
    "evaluate", "feature_names_of", "figure", "grid_cloud", "grid_label", "load_grid",
    "paper_agreement", "probability", "product_pairs", "rise_labels", "second_look_p",
    "site_terrain", "stands_clear", "terrain_domain", "train",
]
