"""Geometry shared by the stages: the pinhole camera, flight (scan) patterns, WGS84 geodesy."""
