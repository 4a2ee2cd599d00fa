"""A coarse-search model of scenes and its JSON form (`mound.scene_model` v1).

p(mound | x) = sigma(a * w^T phi(z(x)) + b), where x are a position's features
(features.py), z their standardisation (training mean and standard deviation, clipped to
+-6), phi the basis (`none`: z itself, the paper's linear model; `hinge`: z, max(z - 1, 0)
and max(-z - 1, 0), a piecewise-linear response per feature that is still a logistic
regression, eqs. (2)-(3), on a fixed basis), w the weights with the bias last, and (a, b)
the Platt calibration fitted on out-of-fold candidates (identity when none was fitted).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import expit

from mound.classify.features import Standardizer, hinge_basis
from mound.errors import InputError
from mound.jsonio import JsonObject
from mound.scene.features import FeatureSpec
from mound.scene.raster import SceneInfo

SCHEMA = "mound.scene_model"
VERSION = 1
CLIP = 6.0


def expand(z: np.ndarray, basis: str) -> np.ndarray:
    if basis == "none":
        return z
    if basis == "hinge":
        return hinge_basis(z)
    raise InputError(f"model: unknown basis {basis!r} (none, hinge)")


@dataclass(frozen=True)
class Band:
    """A band a scene model reads: its 1-based index in the training scenes, its name
    ("red", or "" when the scenes named none)."""

    index: int
    name: str = ""

    @property
    def label(self) -> str:
        """How features name the band: its name, else band<index>."""
        return self.name or f"band{self.index}"

    def to_doc(self) -> JsonObject:
        return {"index": self.index, "name": self.name}


@dataclass
class SceneModel:
    bands: list[Band]
    spec: FeatureSpec
    basis: str
    scaler: Standardizer
    w: np.ndarray
    res_m: float
    calibration: dict[str, float] = field(default_factory=lambda: {"a": 1.0, "b": 0.0})
    threshold: float = 0.5
    info: dict[str, Any] = field(default_factory=dict)
    clip: bool = True

    def design(self, x: np.ndarray) -> np.ndarray:
        """phi(z(x)) with the bias column last."""
        z = (x - self.scaler.mean) / self.scaler.std
        if self.clip:
            z = np.clip(z, -CLIP, CLIP)
        return np.hstack([expand(z, self.basis), np.ones((x.shape[0], 1))])

    def logit(self, x: np.ndarray, chunk: int = 16_384) -> np.ndarray:
        """Uncalibrated w^T phi(z(x)) (NaN where a row has no features), in chunks of rows."""
        out = np.empty(x.shape[0])
        for k in range(0, x.shape[0], chunk):
            out[k:k + chunk] = self.logit_fm(x[k:k + chunk].T)
        return out

    def logit_fm(self, xt: np.ndarray) -> np.ndarray:
        """The logits of features given feature-major, xt (F, N): design(xt.T) @ w up to
        rounding, without building the expanded design. With a = (w2 - w3) / 2 and
        b = (w2 + w3) / 2 for the hinge weights, w2 . max(z - 1, 0) + w3 . max(-z - 1, 0) =
        a . (z - clip(z, -1, 1)) + b . (max(|z|, 1) - 1), and z, clip(z, -1, 1) and |z| are
        affine in x clipped at mean +- 6 std and +- 1 std: five passes over the features
        instead of eleven (the logit was half of the scoring time)."""
        f = self._folded
        mean, std = f["mean"], f["std"]
        x = np.clip(xt, f["lo"], f["hi"]) if self.clip else np.array(xt)
        # einsum, not BLAS: OpenBLAS's own threads spin against the scorer's (2 scoring
        # threads took as long as one)
        out = np.einsum("f,fn->n", f["w_x"], x)
        out += f["const"]
        if self.basis == "hinge":
            out -= np.einsum("f,fn->n", f["w_c"], np.clip(x, mean - std, mean + std))
            np.subtract(x, mean, out=x)
            np.abs(x, out=x)
            out += np.einsum("f,fn->n", f["w_m"], np.maximum(x, std, out=x))
        return out

    @functools.cached_property
    def _folded(self) -> dict[str, Any]:
        n = self.scaler.mean.shape[0]
        mean, std = self.scaler.mean, self.scaler.std
        w1 = self.w[:n]
        const = float(self.w[-1])
        if self.basis == "hinge":
            a = (self.w[n:2 * n] - self.w[2 * n:3 * n]) / 2
            b = (self.w[n:2 * n] + self.w[2 * n:3 * n]) / 2
            w1 = w1 + a
            # - a . clip(z, -1, 1) = - (a / std) . clip(x, ...) + (a / std) . mean
            const += float((a / std) @ mean) - float(b.sum())
        else:
            a = b = np.zeros(n)
        return {"mean": mean[:, None], "std": std[:, None],
                "lo": (mean - CLIP * std)[:, None], "hi": (mean + CLIP * std)[:, None],
                "w_x": w1 / std, "w_c": a / std, "w_m": b / std,
                "const": const - float((w1 / std) @ mean)}

    def calibrate(self, logit: np.ndarray) -> np.ndarray:
        return expit(self.calibration["a"] * logit + self.calibration["b"])

    def predict(self, x: np.ndarray) -> np.ndarray:
        return self.calibrate(self.logit(x))

    def band_indices(self, scene: SceneInfo) -> list[int]:
        """The scene's 1-based bands for this model's bands: by name where the model and
        the scene both name them, else by index; InputError when they do not match."""
        out = []
        named = any(scene.band_names)
        for b in self.bands:
            if b.name and named:
                if b.name not in scene.band_names:
                    raise InputError(f"{scene.path}: has no band {b.name!r}, which the model "
                                     f"needs (its bands: {', '.join(scene.band_names)})")
                out.append(scene.band_names.index(b.name) + 1)
            else:
                if b.index > scene.count:
                    raise InputError(f"{scene.path}: has {scene.count} bands; the model needs "
                                     f"band {b.index} ({b.name or 'unnamed'})")
                out.append(b.index)
        want = self.info.get("band_count")
        if not named and want is not None and want != scene.count:
            raise InputError(f"{scene.path}: {scene.count} bands, the model was trained on "
                             f"{want}-band scenes; name the bands (--band-names) so that they "
                             "can be matched")
        if not 2 / 3 <= scene.res_m / self.res_m <= 1.5:
            raise InputError(f"{scene.path}: pixels of {scene.res_m:g} m; the model was trained "
                             f"at {self.res_m:g} m (resample the scene to within 2/3-1.5x)")
        return out

    def to_doc(self) -> JsonObject:
        return {"schema": SCHEMA, "version": VERSION,
                "bands": [b.to_doc() for b in self.bands],
                "features": {**self.spec.to_doc(), "names": self.spec.names()},
                "basis": self.basis, "resolution_m": self.res_m,
                "mean": self.scaler.mean.tolist(), "std": self.scaler.std.tolist(),
                "weights": self.w.tolist(), "clip": self.clip,
                "calibration": self.calibration, "threshold": self.threshold, **self.info}

    @classmethod
    def from_doc(cls, doc: dict[str, Any], source: str) -> SceneModel:
        try:
            bands = doc["bands"]
            if (not isinstance(bands, list) or not bands or not all(
                    isinstance(b, dict) and isinstance(b.get("index"), int)
                    and not isinstance(b.get("index"), bool) and 1 <= b["index"] <= 10_000
                    and isinstance(b.get("name", ""), str) for b in bands)):
                raise InputError(f"{source}: bands: expected [{{index, name}}] with 1-based "
                                 "indices")
            chosen = [Band(b["index"], b.get("name", "")) for b in bands]
            labels = [b.label for b in chosen]
            feats = doc["features"]
            if not isinstance(feats, dict):
                raise InputError(f"{source}: features: expected an object")
            spec = FeatureSpec.from_doc(feats, labels)
            basis = doc.get("basis", "none")
            if basis not in ("none", "hinge"):
                raise InputError(f"{source}: basis: expected 'none' or 'hinge'")
            n = len(spec.names())
            width = n * (3 if basis == "hinge" else 1) + 1
            arrays = {}
            for key, size in (("mean", n), ("std", n), ("weights", width)):
                a = np.asarray(doc[key], dtype=np.float64)
                if a.shape != (size,) or not np.all(np.isfinite(a)):
                    raise InputError(f"{source}: {key} must be {size} finite numbers")
                arrays[key] = a
            if np.any(arrays["std"] <= 0):
                raise InputError(f"{source}: std must be > 0")
            res = float(doc["resolution_m"])
            if not 0 < res < 1e4:
                raise InputError(f"{source}: resolution_m must be > 0")
            cal = doc.get("calibration", {"a": 1.0, "b": 0.0})
            cal = {"a": float(cal["a"]), "b": float(cal["b"])}
            thr = float(doc.get("threshold", 0.5))
            if not all(np.isfinite([cal["a"], cal["b"], thr])) or not 0 <= thr <= 1:
                raise InputError(f"{source}: calibration and threshold must be finite, "
                                 "threshold in [0, 1]")
            keep = {k: v for k, v in doc.items() if k not in (
                "schema", "version", "bands", "features", "basis", "resolution_m", "mean",
                "std", "weights", "calibration", "threshold", "clip")}
            return cls(bands=chosen,
                       spec=spec, basis=basis,
                       scaler=Standardizer(arrays["mean"], arrays["std"]),
                       w=arrays["weights"], res_m=res, calibration=cal, threshold=thr,
                       info=keep, clip=bool(doc.get("clip", True)))
        except KeyError as e:
            raise InputError(f"{source}: {e.args[0]}: missing required field") from None
        except (TypeError, ValueError, AttributeError) as e:
            if isinstance(e, InputError):
                raise
            raise InputError(f"{source}: malformed scene model ({str(e)[:100]})") from None


def from_classifier(model: Any, band_indices: list[int], res_m: float,
                    resample_m: float) -> SceneModel:
    """A Statlog classifier (mound.classify.model.Model) as a scene model of the paper's
    3 x 3 features: its bands (all four, or its one band) taken from `band_indices`."""
    bands = band_indices if model.band is None else [band_indices[model.band]]
    labels = [f"band{k}" for k in bands]
    spec = FeatureSpec("paper", resample_m=resample_m, band_labels=labels)
    return SceneModel(bands=[Band(k) for k in bands], spec=spec,
                      basis="none", scaler=model.scaler, w=model.w, res_m=res_m, clip=False,
                      info={"source": "mound.classifier (Statlog)"})
