"""`mound_recon`'s options as the Python side chooses them, typed (issue 70: they were argv
string tuples): each spec holds what it sets (None: the tool's own default), checks it,
says it as the tool's flags (`argv`) and as a document (`to_doc`, what a site's key
digests)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from mound.errors import InputError


def _flags(values: dict[str, object]) -> tuple[str, ...]:
    """--name value of each set value, in the order given (numbers as %g)."""
    out: list[str] = []
    for name, value in values.items():
        if value is None:
            continue
        text = f"{value:g}" if isinstance(value, float) else str(value)
        out += ["--" + name.replace("_", "-"), text]
    return tuple(out)


def _positive(name: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(f"{name}: {value!r}: must be a number > 0")


@dataclass(frozen=True)
class ReconstructOptions:
    """`mound_recon reconstruct`'s feature settings (None: the tool's, COLMAP's density
    for real photos)."""

    max_features: int | None = None
    contrast_threshold: float | None = None

    def __post_init__(self) -> None:
        _positive("max_features", self.max_features)
        _positive("contrast_threshold", self.contrast_threshold)

    def argv(self) -> tuple[str, ...]:
        return _flags(asdict(self))

    def to_doc(self) -> dict[str, object]:
        return asdict(self)


@dataclass(frozen=True)
class DensifyOptions:
    """`mound_recon densify`'s settings (None: the tool's; the clouds the shipped verdict
    models were trained on)."""

    max_image_size: int | None = None
    resolution_m: float | None = None

    def __post_init__(self) -> None:
        _positive("max_image_size", self.max_image_size)
        _positive("resolution_m", self.resolution_m)

    def argv(self) -> tuple[str, ...]:
        return _flags(asdict(self))

    def to_doc(self) -> dict[str, object]:
        return asdict(self)


@dataclass(frozen=True)
class VerdictOptions:
    """`mound_recon verdict`'s: the paper's test against a reference cloud (`reference`,
    an absolute path) instead of the reference-free verdict (None)."""

    reference: str | None = None

    def argv(self) -> tuple[str, ...]:
        return () if self.reference is None else ("--reference", self.reference)

    def to_doc(self) -> dict[str, object]:
        return asdict(self)
