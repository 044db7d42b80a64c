"""The model at the console's ranges: the expected Eq. (4) reading beside the four curves, the
paper's curves for plotting, a measured PSF, recomputation off the measurement thread; and the
session's [weather] and [simulation] tables."""

import time

import numpy as np
import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.prediction import CURVES, EXPECTED, PAPER_CURVES, ModelPredictor
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.psf import GaussianPsf
from snrmon.model.snr import predict


def test_lookup_has_the_four_curves_and_the_expected_reading():
    p = ModelPredictor({"mwir": "mwir"}, "uav1", air_temp_k=290.0)
    out = p("mwir", 451.0)
    banded = ("small_corrected", "large_corrected", EXPECTED)
    edges = {f"{c}_{e}" for c in banded for e in ("lower", "upper")}
    assert set(out) == {*CURVES, EXPECTED, "resolved_small", *edges}
    direct = predict(load_sensor("mwir"), load_target("uav1"), [451.0], air_temp_k=290.0)
    assert out["small_corrected"] == pytest.approx(direct.snr_small_corrected[0], rel=2e-3)
    assert out[EXPECTED] == pytest.approx(direct.expected_eq4[0], rel=0.01)
    # the model's uncertainty band at the range (section 9), the model's own numbers
    for c in banded:
        assert out[f"{c}_lower"] == pytest.approx(direct.lower[c][0], rel=0.01), c
        assert out[f"{c}_upper"] == pytest.approx(direct.upper[c][0], rel=0.01), c
        assert out[f"{c}_lower"] < out[c] < out[f"{c}_upper"], c
    assert p.expected_rule == EXPECTED  # the reading a live measurement is compared against
    curves = p.curve("mwir")
    assert set(PAPER_CURVES) <= set(curves) and f"{EXPECTED} band" in curves


def test_a_measured_psf_replaces_the_presets_and_asynchronous_recompute():
    p = ModelPredictor({"mwir": "mwir"}, "uav1", asynchronous=True)
    before = p("mwir", 451.0)["small_corrected"]
    p.set_psf("mwir", GaussianPsf(0.8), wait=True)
    after = p("mwir", 451.0)["small_corrected"]
    assert after / before == pytest.approx(1.8, rel=0.15)  # PVF 0.148 against 0.082
    p.set_background("mwir", 270.0)  # returns at once; the curves follow when ready
    assert p.background_temp_k["mwir"] == 270.0
    deadline = time.monotonic() + 30
    while p("mwir", 451.0)["small_corrected"] == after and time.monotonic() < deadline:
        time.sleep(0.05)
    assert p("mwir", 451.0)["small_corrected"] > after


def test_session_weather_and_simulation_tables():
    base = {"cameras": {"mwir": {"sensor": "mwir"}}}
    cfg = session_config_from_dict(
        {**base, "weather": {"air_temp_c": 21.5}, "simulation": {"sky_temp_k": 280.0}}
    )
    assert cfg.air_temp_k == pytest.approx(294.65)
    assert session_config_from_dict(base).air_temp_k is None
    with pytest.raises(ValueError, match=r'\[weather\] air_temp_c = "warm": expected an air temp'):
        session_config_from_dict({**base, "weather": {"air_temp_c": "warm"}})
    with pytest.raises(ValueError, match=r"\[weather\]: unknown key 'sky'"):
        session_config_from_dict({**base, "weather": {"sky": 1}})
    assert np.isfinite(cfg.air_temp_k)
