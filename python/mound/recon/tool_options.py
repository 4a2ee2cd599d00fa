"""`mound_recon`'s options as the Python side chooses them, typed (issue 70: they were argv
string tuples): each spec holds what it sets (None: the tool's own default), checks its
numbers, says it as the tool's flags (`argv`) and as a document (`to_doc`, what a site's
key digests)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from mound.jsonio import JsonObject


@dataclass(frozen=True)
class ToolOptions:
    """A tool's options: every field a flag (--max-features for max_features), None left
    out; a number must be finite and > 0."""

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if isinstance(value, int | float) and not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: {value!r}: must be a number > 0")

    def argv(self) -> tuple[str, ...]:
        out: list[str] = []
        for name, value in asdict(self).items():
            if value is not None:
                text = f"{value:g}" if isinstance(value, float) else str(value)
                out += ["--" + name.replace("_", "-"), text]
        return tuple(out)

    def to_doc(self) -> JsonObject:
        return asdict(self)


@dataclass(frozen=True)
class ReconstructOptions(ToolOptions):
    """`mound_recon reconstruct`'s feature settings (None: the tool's, COLMAP's density
    for real photos)."""

    max_features: int | None = None
    contrast_threshold: float | None = None


@dataclass(frozen=True)
class DensifyOptions(ToolOptions):
    """`mound_recon densify`'s settings (None: the tool's: the clouds the shipped verdict
    models were trained on)."""

    max_image_size: int | None = None
    resolution_m: float | None = None


@dataclass(frozen=True)
class VerdictOptions(ToolOptions):
    """`mound_recon verdict`'s: the paper's test against a reference cloud (`reference`,
    an absolute path) instead of the reference-free verdict (None)."""

    reference: str | None = None
