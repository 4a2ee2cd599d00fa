"""Where the project's artefacts live: the build directory, the shared data, the repo."""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]


def build_dir() -> Path:
    """The CMake build directory ($MOUND_BUILD_DIR, default <repo>/build)."""
    return Path(os.environ.get("MOUND_BUILD_DIR", REPO_ROOT / "build"))


def shared_data_dir() -> Path:
    """The shared test/benchmark data ($MOUND_SHARED_DATA, default <repo>/../shared/data)."""
    return Path(os.environ.get("MOUND_SHARED_DATA", REPO_ROOT.parent / "shared" / "data"))
