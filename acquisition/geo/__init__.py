"""Geometry: GPS to slant range and to camera pixel, pointing calibration, GPS cues for the
tracker."""
