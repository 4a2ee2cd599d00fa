"""The coarse-search classifier's training defaults, apart from the trainer so that the
command line reads them without importing scipy (coarse.py re-exports them)."""

from __future__ import annotations

DEFAULT_L2 = 1e-4
DEFAULT_BAND = 1  # red: best held-out AUC on sat.trn (`mound classify bands`, docs/stages.md)
