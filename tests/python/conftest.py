"""Shared fixtures: the built tools and the shared data (../shared/data)."""

from __future__ import annotations

from pathlib import Path

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


@pytest.fixture(autouse=True)
def data_cache(shared_data: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Every test reads the public data sets from ../shared/data (byte-identical copies)."""
    monkeypatch.setenv("MOUND_DATA", str(shared_data))
    return shared_data


@pytest.fixture(scope="session")
def example_sites() -> Path:
    return REPO_ROOT / "data" / "sites.json"


@pytest.fixture(scope="session")
def mound_render() -> Path:
    return built_tool("mound_render")


@pytest.fixture(scope="session")
def mound_recon() -> Path:
    return built_tool("mound_recon")
