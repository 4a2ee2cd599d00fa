"""Public data sets in a local cache, downloaded once and checked by sha256.

The cache is $MOUND_DATA, or ~/.cache/mound-survey (XDG_CACHE_HOME respected). Tests point
$MOUND_DATA at ../shared/data, which holds byte-identical copies. A download goes to a
temporary folder inside the cache; only files whose checksums match are moved into place,
so a failed or corrupted download leaves nothing behind.
"""

from __future__ import annotations

import hashlib
import io
import os
import shutil
import tempfile
import urllib.request
import zipfile
from dataclasses import dataclass
from pathlib import Path

from mound.errors import InputError


@dataclass(frozen=True)
class DataSet:
    name: str                    # folder inside the cache
    url: str                     # a zip archive
    files: dict[str, str]        # file name -> sha256 of the extracted file
    licence: str


STATLOG = DataSet(
    name="statlog",
    url="https://archive.ics.uci.edu/static/public/146/statlog+landsat+satellite.zip",
    files={
        "sat.trn": "6da888aa398f4dd56a85bb7114f7206896a360b7af1d790450f64dbdb8493fc5",
        "sat.tst": "0045be0391420a35a69e8d2b0a4ff4b032a4aa03feebba0d89b9aa3e2d42c212",
    },
    licence="CC BY 4.0, Srinivasan (1993), UCI Machine Learning Repository, doi:10.24432/C55887",
)


def cache_dir() -> Path:
    env = os.environ.get("MOUND_DATA")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mound-survey"


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def verify(path: Path, expected: str) -> None:
    got = sha256_of(path)
    if got != expected:
        raise InputError(f"{path}: wrong sha256 {got} (expected {expected}); "
                         "the file is corrupted or not the published version")


def dataset_path(ds: DataSet, file: str) -> Path:
    """Path of `file` of `ds` in the cache; InputError if it is missing (run fetch)."""
    path = cache_dir() / ds.name / file
    if not path.is_file():
        raise InputError(f"{path}: missing; run `mound data fetch` (or set MOUND_DATA)")
    return path


def fetch(ds: DataSet, url: str | None = None, timeout_s: float = 60.0) -> Path:
    """Downloads `ds` into the cache unless present and valid; returns its folder."""
    target = cache_dir() / ds.name
    if target.is_dir() and all(
        (target / f).is_file() and sha256_of(target / f) == h for f, h in ds.files.items()
    ):
        return target
    url = url or ds.url
    cache_dir().mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f".{ds.name}.", dir=cache_dir()) as tmp:
        try:
            with urllib.request.urlopen(url, timeout=timeout_s) as resp:
                payload = resp.read()
        except OSError as e:
            raise InputError(
                f"{url}: download failed ({e}); without the network, set MOUND_DATA to a "
                f"folder holding {ds.name}/ ({', '.join(ds.files)})") from e
        try:
            archive = zipfile.ZipFile(io.BytesIO(payload))
        except zipfile.BadZipFile as e:
            raise InputError(f"{url}: not a zip archive ({e})") from e
        staged = Path(tmp)
        with archive:
            names = {Path(n).name: n for n in archive.namelist()}
            for file, expected in ds.files.items():
                if file not in names:
                    raise InputError(f"{url}: archive lacks {file}")
                out = staged / file
                with archive.open(names[file]) as src, open(out, "wb") as dst:
                    shutil.copyfileobj(src, dst)
                verify(out, expected)
        target.mkdir(parents=True, exist_ok=True)
        for file in ds.files:
            os.replace(staged / file, target / file)
    return target
