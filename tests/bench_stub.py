"""A benchmark module for tests of ``benchmarks/fresh_process.py``: figures of the types real
benchmarks return (NumPy scalars and arrays, NaN, tuples); a negative duration fails."""

from __future__ import annotations

import os

import numpy as np


def run(duration_s: float) -> dict:
    if duration_s < 0:
        raise ValueError(f"a negative duration: {duration_s}")
    return {
        "pid": os.getpid(),
        "frames": np.int64(3),
        "fps": np.float32(0.5),
        "per_run": np.arange(2),
        "not_measured": float("nan"),
        "pair": (1, 2),
        "seconds": duration_s,
    }
