"""A trained coarse-search classifier and its versioned JSON form (mound.classifier v1)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mound.classify.features import Standardizer, band_columns
from mound.classify.logistic import predict_proba
from mound.errors import InputError
from mound.jsonio import JsonObject

SCHEMA = "mound.classifier"
VERSION = 1


@dataclass
class Model:
    band: int | None              # 0..3, or None for all 36 features
    scaler: Standardizer
    w: np.ndarray                 # weights of the standardised features, then the bias
    l2: float
    solver: str
    target_class: int = 2
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def columns(self) -> list[int]:
        return band_columns(self.band)

    def predict(self, x36: np.ndarray) -> np.ndarray:
        """Mound (target-class) probability of each row of raw 36-column pixel data."""
        return predict_proba(self.w, self.scaler.design(x36[:, self.columns]))

    def to_doc(self) -> JsonObject:
        return {
            "schema": SCHEMA, "version": VERSION,
            "features": {"kind": "all" if self.band is None else "band", "band": self.band,
                         "columns": self.columns},
            "target_class": self.target_class,
            "mean": self.scaler.mean.tolist(), "std": self.scaler.std.tolist(),
            "weights": self.w.tolist(), "l2": self.l2, "solver": self.solver,
            "info": self.info,
        }

    @classmethod
    def from_doc(cls, doc: dict[str, Any], source: str) -> Model:
        try:
            feats = doc["features"]
            band = feats.get("band")
            if feats.get("kind") not in ("band", "all"):
                raise InputError(f"{source}: features.kind must be 'band' or 'all'")
            if band is not None and band not in (0, 1, 2, 3):
                raise InputError(f"{source}: features.band must be 0..3")
            n = len(band_columns(band))
            arrays = {}
            for key, size in (("mean", n), ("std", n), ("weights", n + 1)):
                a = np.asarray(doc[key], dtype=np.float64)
                if a.shape != (size,) or not np.all(np.isfinite(a)):
                    raise InputError(f"{source}: {key} must be {size} finite numbers")
                arrays[key] = a
            return cls(band=band, scaler=Standardizer(arrays["mean"], arrays["std"]),
                       w=arrays["weights"], l2=float(doc.get("l2", 0.0)),
                       solver=str(doc.get("solver", "?")),
                       target_class=int(doc.get("target_class", 2)), info=doc.get("info", {}))
        except KeyError as e:
            raise InputError(f"{source}: {e.args[0]}: missing required field") from None
        except (TypeError, ValueError) as e:
            raise InputError(f"{source}: malformed classifier ({e})") from None
