"""Closed-loop validation of the simulated field test (issue 5).

The whole console runs against the simulators through the real interfaces (camera processes
writing shared-memory rings, an NMEA GPS and an LDM rangefinder on pseudo-terminals); its
measured 100-frame peak SNR at each detected stop is held against the truth the renderer knows,
and that truth against the model's average-PVF prediction for the simulated configuration.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from model.noise import temporal_noise_e
from model.presets import load_sensor, load_target
from model.pvf import average_pvf
from model.snr import target_contrast_electrons
from sim.feed import FlightCameraFeed
from sim.flight import FlightConfig, FlightPlan
from sim.from_model import scene_config_from_model
from snrmon.rig import rig as hil
from snrmon.rig.rig import HilOptions, HilRig

SKY_K = 280.0


def _check_stop(stop: dict) -> None:
    truth, measured = stop["truth_snr"], stop["measured_snr_mean"]
    where = f"{stop['camera']} at {stop['planned_range_m']:.0f} m"
    assert stop["n_frames"] == 100, f"{where}: only {stop['n_frames']} valid frames"
    if truth >= 8:
        assert measured == pytest.approx(truth, rel=0.10), where
    elif truth >= 5:
        assert measured == pytest.approx(truth, rel=0.15), where


@pytest.mark.slow
def test_hil_measures_the_truth_at_every_stop_without_dropping_frames():
    opts = HilOptions(
        seed=1, speed=1.0, stops_m=(199.0, 508.0), transit_mps=25.0, start_range_m=150.0
    )
    with HilRig(opts) as rig:
        result = rig.run()
    stops = result["stops"]
    assert sorted((s["camera"], s["planned_range_m"]) for s in stops) == [
        ("lwir", 199.0), ("lwir", 508.0), ("mwir", 199.0), ("mwir", 508.0)
    ]  # fmt: skip
    for s in stops:
        _check_stop(s)
        assert s["lrf_range_m"] == pytest.approx(s["planned_range_m"], abs=1.0)
        assert s["gps_range_m"] == pytest.approx(s["planned_range_m"], abs=2.0)
        assert set(s["model_snr"]) == {"small", "large", "small_corrected", "large_corrected"}
    for cam, frames in result["frames"].items():
        assert frames["dropped"] == 0, cam
        assert frames["received"] > 0, cam


@pytest.mark.slow
def test_hil_first_click_at_37m_holds_the_resolved_drone_and_reads_its_truth():
    """Issue 14: the operator's first act, a click on the drone at the closest stop. The drone
    covers more than the 7x7 box (MWIR ~12 px across); the track holds it, the stop gets its
    100 frames, and the background outside the drone's extent gives the truth within 15 %."""
    opts = HilOptions(seed=4, speed=2.0, stops_m=(37.0, 126.0), hover_s=6.0)
    with HilRig(opts) as rig:
        result = rig.run()
    stops = {(s["camera"], s["planned_range_m"]): s for s in result["stops"]}
    assert set(stops) == {(c, r) for c in ("mwir", "lwir") for r in (37.0, 126.0)}
    assert result["operator_clicks"] == {"mwir": 1, "lwir": 1}  # one click, at 37 m
    for (cam, rng), s in stops.items():
        where = f"{cam} at {rng:.0f} m"
        assert s["n_frames"] == 100, f"{where}: only {s['n_frames']} valid frames"
        tolerance = 0.15 if s["resolved"] else 0.10
        assert s["measured_snr_mean"] == pytest.approx(s["truth_snr"], rel=tolerance), where
    assert stops[("mwir", 37.0)]["background"] == "extent_rim"
    assert stops[("lwir", 37.0)]["background"] == "extent_rim"
    assert stops[("mwir", 37.0)]["truth_snr"] > 300  # the regime the 7x7 rim read as 1-3


@pytest.mark.slow
def test_hil_low_snr_stops_with_another_seed(monkeypatch):
    """Also: a stop is summarised when the console freezes its row, so its truth survives its
    frames leaving the rig's bounded log (5 s here, 120 s in use) before the flight ends."""
    monkeypatch.setattr(hil, "LOG_S", 5.0)
    opts = HilOptions(
        seed=2,
        speed=2.0,
        cameras=("lwir",),
        stops_m=(393.0, 760.0),
        transit_mps=40.0,
        start_range_m=350.0,
    )
    with HilRig(opts) as rig:
        result = rig.run()
    stops = {s["planned_range_m"]: s for s in result["stops"]}
    assert set(stops) == {393.0, 760.0}
    assert 5.0 <= stops[760.0]["truth_snr"] < 12.0  # the low-SNR regime is exercised
    for s in stops.values():
        _check_stop(s)
    first = rig.session.stop_detector.stops[0]
    log = rig.cameras["lwir"].log
    assert len(log) == log.maxlen == 5 * 30 * 2
    assert first.t_end_ns is not None and log[0][0] > first.t_end_ns  # its frames are gone


@pytest.mark.slow
def test_fixed_pattern_noise_removed_by_the_background_reference():
    """With fixed-pattern noise 2.5x the temporal noise, the sky reference taken before launch
    brings the measurement back to the truth; on raw frames (over the same 100 frames) the
    console reports an SNR lower by about sqrt(1 + 2.5^2). The tolerance is statistical: the
    std of a 24-pixel rim samples the fixed pattern with a relative spread of
    1/sqrt(2 x 23) = 15% for one rim position, less as the hover drifts over a few; seeds 0-5
    gave factors 2.28-2.94 (mean 2.62) against the nominal 2.69."""
    opts = HilOptions(
        seed=3, speed=1.0, cameras=("lwir",), stops_m=(393.0,), transit_mps=30.0,
        start_range_m=360.0, fpn=True,
    )  # fmt: skip
    with HilRig(opts) as rig:
        result = rig.run()
        status = rig.session.status().cameras["lwir"]
    (stop,) = result["stops"]
    _check_stop(stop)
    assert status.reference_frames == opts.reference_frames
    scene = rig.cameras["lwir"].feed.scene
    assert status.fixed_pattern_dn == pytest.approx(2.5 * scene.temporal_noise_dn, rel=0.1)
    factor = stop["measured_snr_mean"] / stop["measured_snr_mean_raw"]
    assert factor == pytest.approx(math.sqrt(1 + 2.5**2), rel=0.2)


@pytest.mark.parametrize(("camera", "range_m"), [("mwir", 451.0), ("lwir", 393.0)])
def test_simulator_truth_approaches_the_model_average_pvf_snr(camera, range_m):
    """Over a hover whose drift covers the sub-pixel phases, the mean noise-free peak over the
    rendered noise equals the model's SNR with the average PVF of the simulated configuration
    (diffraction-limited PSF, Gaussian target of sigma D/2)."""
    sensor, target = load_sensor(camera), load_target("uav1")
    psf = sensor.diffraction_psf()
    scene = scene_config_from_model(sensor, target, sky_temp_k=SKY_K, psf=psf)
    flight = FlightConfig(stops_m=(range_m,), hover_s=20.0, start_range_m=range_m - 5.0, seed=4)
    feed = FlightCameraFeed(scene, flight, fps=sensor.fps, seed=0)
    t0, t1, _ = FlightPlan(flight).stop_windows()[0]
    counters = np.arange(int(t0 * sensor.fps) + 1, int(t1 * sensor.fps), 3)
    truths = [feed.truth(int(c)) for c in counters]
    truth_snr = float(np.mean([t.truth_snr for t in truths]))
    size_px = target.small_m / (range_m * sensor.ifov_rad)
    pvf = average_pvf(psf, sensor.fill_factor, target_sigma_px=size_px / 2)
    signal_e = target_contrast_electrons(sensor, target, range_m, background_temp_k=SKY_K)
    model_snr = pvf * signal_e / temporal_noise_e(sensor, SKY_K)
    assert truth_snr == pytest.approx(model_snr, rel=0.10)
    assert not math.isclose(truth_snr, 0.0)
