"""Where the project's artefacts live: the build directory, the shared data, the repo."""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]


def build_dir() -> Path:
    """The CMake build directory ($MOUND_BUILD_DIR, default <repo>/build).

    Every path to a compiled tool goes through here (mound.native, the tests), so with
    $MOUND_TOOL_TRACE set it appends the running test's id ($PYTEST_CURRENT_TEST, which
    subprocesses and Dask workers inherit) to that file: `make test` learns which tests run
    compiled code, and `make test-asan` runs only those again (tools/native_tests.py).
    """
    trace = os.environ.get("MOUND_TOOL_TRACE")
    test = os.environ.get("PYTEST_CURRENT_TEST")
    if trace and test:
        with open(trace, "a", encoding="utf-8") as f:  # one short line: an atomic append
            f.write(test.rsplit(" (", 1)[0] + "\n")
    return Path(os.environ.get("MOUND_BUILD_DIR", REPO_ROOT / "build"))


def shared_data_dir() -> Path:
    """The shared test/benchmark data ($MOUND_SHARED_DATA, default <repo>/../shared/data)."""
    return Path(os.environ.get("MOUND_SHARED_DATA", REPO_ROOT.parent / "shared" / "data"))
