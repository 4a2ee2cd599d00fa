"""mound-survey: find and verify ancient burial mounds from satellite data and a UAV."""

__version__ = "0.1.0"
