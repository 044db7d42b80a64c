"""The one per-frame engine: correction, measurement, tracking, noise and sky figures, status, for
live, replay and batch alike."""
