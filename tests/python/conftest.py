"""Shared fixtures: the built tools and the shared data (../shared/data)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mound.paths import REPO_ROOT, build_dir, shared_data_dir


def built_tool(name: str) -> Path:
    path = build_dir() / name
    if not path.exists():
        pytest.fail(f"{path} missing: run `make` first (the tests use the real binary)")
    return path


@pytest.fixture(scope="session")
def mound_plan() -> Path:
    return built_tool("mound_plan")


@pytest.fixture(scope="session")
def shared_data() -> Path:
    path = shared_data_dir()
    if not path.is_dir():
        pytest.fail(f"shared data not found at {path} (set MOUND_SHARED_DATA)")
    return path


@pytest.fixture(scope="session", autouse=True)
def data_cache(shared_data: Path) -> Iterator[Path]:
    """Every test, and every module fixture, reads the public data sets from ../shared/data
    (byte-identical copies), whatever order the tests run in."""
    with pytest.MonkeyPatch.context() as env:
        env.setenv("MOUND_DATA", str(shared_data))
        yield shared_data


@pytest.fixture(scope="session")
def example_sites() -> Path:
    return REPO_ROOT / "data" / "sites.json"


@pytest.fixture(scope="session")
def mound_render() -> Path:
    return built_tool("mound_render")


@pytest.fixture(scope="session")
def mound_recon() -> Path:
    return built_tool("mound_recon")


@pytest.fixture(scope="module")
def dem_path(shared_data: Path) -> Path:
    """The shared 1 m laser DEM (Slovenia, EPSG:3794, EGM96-like orthometric heights)."""
    return shared_data / "dem" / "TM1_564_146.tif"


@pytest.fixture(scope="module")
def raw(dem_path: Path) -> tuple[Any, Any]:
    """Its heights and geotransform, straight from the file (the tests' reference)."""
    import numpy as np
    import rasterio

    with rasterio.open(dem_path) as ds:
        return ds.read(1).astype(np.float64), ds.transform


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Under $MOUND_TOOL_TRACE (tools/native_tests.py), the tests that take a built tool as
    a fixture are traced up front: a session fixture locates its tool only once."""
    trace = os.environ.get("MOUND_TOOL_TRACE")
    if not trace:
        return
    tools = {"mound_plan", "mound_render", "mound_recon"}
    with open(trace, "a", encoding="utf-8") as f:
        for item in items:
            if tools & set(getattr(item, "fixturenames", ())):
                f.write(item.nodeid + "\n")
