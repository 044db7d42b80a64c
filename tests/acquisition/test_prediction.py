"""The model at the console's ranges: the expected Eq. (4) reading beside the four curves, the
paper's curves for plotting, a measured PSF, recomputation off the measurement thread; and the
session's [weather] and [simulation] tables."""

import time

import numpy as np
import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.prediction import (
    CURVES,
    EXPECTED_CURVES,
    EXPECTED_EXTENT,
    EXPECTED_RIM,
    PAPER_CURVES,
    ModelPredictor,
)
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.psf import GaussianPsf
from snrmon.model.snr import predict


def test_lookup_has_the_four_curves_and_the_expected_reading():
    p = ModelPredictor({"mwir": "mwir"}, "uav1", air_temp_k=290.0)
    out = p("mwir", 451.0)
    banded = ("small_corrected", "large_corrected", *EXPECTED_CURVES)
    edges = {f"{c}_{e}" for c in banded for e in ("lower", "upper")}
    assert set(out) == {*CURVES, *EXPECTED_CURVES, "resolved_small", *edges}
    direct = predict(load_sensor("mwir"), load_target("uav1"), [37.0, 451.0], air_temp_k=290.0)
    assert out["small_corrected"] == pytest.approx(direct.snr_small_corrected[1], rel=2e-3)
    for name in (EXPECTED_RIM, EXPECTED_EXTENT):
        assert out[name] == pytest.approx(direct.snr(name)[1], rel=0.01)
        assert f"{name} band" in p.curve("mwir")
    # the model's uncertainty band at the range (section 9), the model's own numbers
    for c in banded:
        assert out[f"{c}_lower"] == pytest.approx(direct.lower[c][1], rel=0.01), c
        assert out[f"{c}_upper"] == pytest.approx(direct.upper[c][1], rel=0.01), c
        assert out[f"{c}_lower"] < out[c] < out[f"{c}_upper"], c
    assert set(PAPER_CURVES) <= set(p.curve("mwir"))
    # the two rules, each labelled: the same on the compact drone at 451 m; at 37 m the
    # paper's 7x7 rim lies on the drone and reads it against itself
    assert out[EXPECTED_RIM] == pytest.approx(out[EXPECTED_EXTENT], rel=0.02)
    close = p("mwir", 37.0)
    assert close[EXPECTED_EXTENT] > 50 * close[EXPECTED_RIM]


def test_measured_noise_is_per_camera():
    from snrmon.model.noise import MeasuredNoise

    noise = MeasuredNoise(temporal_dn=4.0, spatial_dn=3.0)
    p = ModelPredictor({"mwir": "mwir", "lwir": "lwir"}, "uav1", measured_noise={"mwir": noise})
    own = ModelPredictor({"lwir": "lwir"}, "uav1")
    mw = predict(load_sensor("mwir"), load_target("uav1"), [451.0], measured_noise=noise)
    assert p("mwir", 451.0)["small_corrected"] == pytest.approx(mw.snr_small_corrected[0], 2e-3)
    assert p("lwir", 451.0) == own("lwir", 451.0)  # no measured noise given: the model's


def test_set_measured_noise_recomputes_that_camera_once_and_none_returns_to_the_models():
    from snrmon.model.noise import MeasuredNoise

    grid = np.geomspace(100.0, 2000.0, 8)  # a few ranges: the scaling holds at each
    p = ModelPredictor({"mwir": "mwir", "lwir": "lwir"}, "uav1", ranges_m=grid)
    # the four curves and the paper's: signal over noise (the expected Eq. (4) readings are
    # not proportional to it: the estimator's floor far out, the MWIR rim on the drone close in)
    scaled = (*CURVES, *PAPER_CURVES)
    model = {c: {n: p.curve(c)[n][1].copy() for n in scaled} for c in ("mwir", "lwir")}
    # the presets' gains (e-/DN): MWIR chosen for 6.6 DN at a 290 K sky, LWIR for 5.8 DN
    gains = {"mwir": 109.0, "lwir": 2.54e5}
    noise = {
        "mwir": MeasuredNoise(temporal_dn=7.2, spatial_dn=1.9),
        "lwir": MeasuredNoise(5.1, 2.6),
    }
    for camera, other in (("mwir", "lwir"), ("lwir", "mwir")):
        version = p.version
        p.set_measured_noise(camera, noise[camera])
        assert p.version == version + 1 and p.measured_noise == {camera: noise[camera]}
        p.set_measured_noise(
            camera, MeasuredNoise(noise[camera].temporal_dn, noise[camera].spatial_dn)
        )
        p.set_measured_noise("nope", noise[camera])  # a camera it has no curves for: nothing
        assert p.version == version + 1  # the same numbers again: nothing recomputed
        # Eq. 3: signal over noise, so every range's SNR scales by (the model's noise) /
        # (the measured noise in electrons: hypot(sigma_tvh, sigma_vh) DN x the gain)
        sensor = load_sensor(camera)
        assert sensor.gain_e_per_dn == gains[camera]
        own = predict(sensor, load_target("uav1"), [451.0], band=False, expected=False)
        n = noise[camera]
        ratio = own.noise.total / ((n.temporal_dn**2 + n.spatial_dn**2) ** 0.5 * gains[camera])
        for name in scaled:
            got = p.curve(camera)[name][1] / model[camera][name]
            np.testing.assert_allclose(got, ratio, rtol=1e-9, err_msg=f"{camera} {name}")
            np.testing.assert_array_equal(p.curve(other)[name][1], model[other][name])
        built = ModelPredictor({camera: camera}, "uav1", ranges_m=grid, measured_noise=noise)
        for name in EXPECTED_CURVES:  # recomputed as a predictor built with the noise has them
            np.testing.assert_allclose(p.curve(camera)[name][1], built.curve(camera)[name][1])
        p.set_measured_noise(camera, None)
        assert p.version == version + 2 and p.measured_noise == {}
        for name in scaled:
            np.testing.assert_allclose(p.curve(camera)[name][1], model[camera][name], rtol=1e-12)


def test_a_model_noise_record_round_trips_and_a_damaged_one_is_named():
    from snrmon.acquisition.prediction import (
        MeasuredNoise,
        measured_noise_from_record,
        measured_noise_record,
    )

    noise = MeasuredNoise(temporal_dn=5.8, spatial_dn=0.4)
    assert measured_noise_record(noise) == {"temporal_dn": 5.8, "spatial_dn": 0.4}
    assert measured_noise_from_record(measured_noise_record(noise)) == noise
    assert measured_noise_record(None) == {} and measured_noise_from_record({}) is None
    for bad, why in (
        ({"temporal_dn": 5.8}, "spatial_dn"),
        ({"temporal_dn": "x", "spatial_dn": 1.0}, "'x'"),
        ({"temporal_dn": -1.0, "spatial_dn": 1.0}, "temporal_dn must be >= 0 DN"),
        ({"temporal_dn": 0.0, "spatial_dn": 0.0}, "infinite"),
    ):
        with pytest.raises(ValueError, match="model_noise event") as err:
            measured_noise_from_record(bad)
        assert why in str(err.value)


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
