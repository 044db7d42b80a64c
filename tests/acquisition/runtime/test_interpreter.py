"""The live settings a session puts on the interpreter while it runs, and puts back."""

from __future__ import annotations

import sys

import numpy as np
from threadpoolctl import threadpool_info

from snrmon.acquisition.runtime.interpreter import SWITCH_INTERVAL_S, LiveInterpreter


def blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def test_the_live_settings_apply_once_and_are_put_back():
    np.ones(4) @ np.ones(4)  # NumPy's BLAS loaded
    old = sys.getswitchinterval()
    sys.setswitchinterval(0.005)
    try:
        before = blas_threads()
        assert before  # NumPy's wheels bring OpenBLAS: there is a pool to limit
        live = LiveInterpreter()
        live.apply()
        live.apply()  # a second start changes nothing, and the first values are kept
        assert sys.getswitchinterval() == SWITCH_INTERVAL_S
        assert blas_threads() == [1] * len(before)
        live.restore()
        assert sys.getswitchinterval() == 0.005
        assert blas_threads() == before
        live.restore()  # a second stop changes nothing
        assert sys.getswitchinterval() == 0.005
    finally:
        sys.setswitchinterval(old)


def test_a_shorter_switch_interval_is_left_alone():
    old = sys.getswitchinterval()
    sys.setswitchinterval(0.0005)
    try:
        live = LiveInterpreter()
        live.apply()
        assert sys.getswitchinterval() == 0.0005
        live.restore()
        assert sys.getswitchinterval() == 0.0005
    finally:
        sys.setswitchinterval(old)
