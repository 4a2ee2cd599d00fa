"""mound-survey: find and verify ancient burial mounds from satellite data and a UAV."""

from importlib.metadata import PackageNotFoundError, version

try:
    # The one version of the project is pyproject.toml's (CMake reads the same line).
    __version__ = version("mound-survey")
except PackageNotFoundError:  # run from the tree without `pip install -e .`
    __version__ = "0+unknown"
