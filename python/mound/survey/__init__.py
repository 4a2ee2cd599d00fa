"""The end-to-end survey (python/mission.py): stages, resume, Dask, the report."""
