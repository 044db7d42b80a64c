"""Radiometric calibration (NUC, DN to radiance/temperature), sky temperature and target
characterization."""
