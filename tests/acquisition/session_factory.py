"""A small simulated session file written with the real recorder, for report and replay tests
(:func:`snrmon.examples.example_session`, under the names these tests use)."""

from __future__ import annotations

from snrmon.examples import NOISE_DN, SHAPE, SITE, SKY_DN, SPOT_XY, T0_NS
from snrmon.examples import ExampleSession as SimulatedSession
from snrmon.examples import example_session as write_session

__all__ = [
    "NOISE_DN",
    "SHAPE",
    "SITE",
    "SKY_DN",
    "SPOT_XY",
    "T0_NS",
    "SimulatedSession",
    "write_session",
]
