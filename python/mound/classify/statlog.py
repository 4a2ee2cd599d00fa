"""The UCI Statlog (Landsat Satellite) data set: 3 x 3 pixels x 4 spectral bands.

Each row holds 36 integers, the four band values of each pixel of a 3 x 3 neighbourhood
in row-major pixel order (so band b of pixel k is column 4k + b), then the class of the
central pixel in {1, 2, 3, 4, 5, 7}; class 2 is "cotton crop". sat.trn has 4,435 rows,
sat.tst 2,000. The documentation asks to train on sat.trn and test once on sat.tst.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mound.datasets import STATLOG, dataset_path, verify
from mound.errors import InputError

N_FEATURES = 36
N_BANDS = 4
CLASSES = (1, 2, 3, 4, 5, 7)
COTTON = 2
EXPECTED_ROWS = {"sat.trn": 4435, "sat.tst": 2000}


@dataclass
class Split:
    x: np.ndarray   # (n, 36) float64 pixel values
    cls: np.ndarray  # (n,) int class labels

    @property
    def y(self) -> np.ndarray:
        """Binary target: +1 cotton crop, -1 the rest."""
        return np.where(self.cls == COTTON, 1.0, -1.0)


def parse(text: str, source: str) -> Split:
    """Parses Statlog rows; InputError naming `source` and the line for any defect."""
    rows: list[list[int]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        if len(fields) != N_FEATURES + 1:
            raise InputError(
                f"{source}:{lineno}: expected {N_FEATURES + 1} columns, got {len(fields)}"
            )
        # Digits only (no sign: "--5" and "-3" are not pixel values), at most 3 of them
        # before int() sees them: a 20-digit value would overflow the int64 array.
        bad = next((v for v in fields if not (v.isascii() and v.isdigit())), None)
        if bad is not None:
            raise InputError(f"{source}:{lineno}: non-numeric value {bad[:20]!r}")
        big = next((v for v in fields[:N_FEATURES] if len(v) > 3 or int(v) > 255), None)
        if big is not None:
            raise InputError(f"{source}:{lineno}: value {big[:20]} outside the 8-bit range 0..255")
        if len(fields[-1]) > 3 or int(fields[-1]) not in CLASSES:
            raise InputError(f"{source}:{lineno}: unknown class {fields[-1][:20]}")
        rows.append([int(v) for v in fields])
    if not rows:
        raise InputError(f"{source}: no data rows")
    arr = np.asarray(rows, dtype=np.int64)
    return Split(x=arr[:, :N_FEATURES].astype(np.float64), cls=arr[:, N_FEATURES])


def load_file(path: Path, expected_sha256: str | None = None,
              expected_rows: int | None = None) -> Split:
    try:
        text = path.read_text(encoding="ascii")
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror})") from e
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not a text file ({e.reason} at byte {e.start})") from e
    split = parse(text, str(path))
    if expected_rows is not None and len(split.cls) != expected_rows:
        raise InputError(f"{path}: {len(split.cls)} rows, expected {expected_rows} "
                         "(truncated file?)")
    if expected_sha256 is not None:
        verify(path, expected_sha256)
    return split


def load(name: str) -> Split:
    """Loads "sat.trn" or "sat.tst" from the data cache, checking rows and checksum."""
    return load_file(dataset_path(STATLOG, name), STATLOG.files[name], EXPECTED_ROWS[name])
