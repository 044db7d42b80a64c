"""The PSF from the flight's frames (acquisition/calibrate/psf_estimate.py, ``snrmon psf``):
on the twin's rendered drone it recovers the twin's own PVF; a resolved or short stop is
refused with the stop and the reason."""

import json

import numpy as np
import pytest

from snrmon.acquisition.calibrate.psf_estimate import (
    PsfEstimateError,
    StopCrops,
    crop_frames,
    estimate_psf,
    observed_phases,
)
from snrmon.model.presets import load_sensor, load_target
from snrmon.sim.optics import TwinSpread, twin_optics
from snrmon.sim.silhouette import silhouette_for

UAV1 = load_target("uav1")


def _hover_crops(sensor, range_m, n=120, amplitude=800.0, seed=5, phases=None):
    """Frames of the twin's drone at random phases with unit white noise, cropped around
    their measured peak as the console does; ``phases``: a list to receive each kept frame's
    centroid offset (x, y) from its peak pixel."""
    optics = twin_optics(sensor, UAV1.temp_k(sensor.name), 280.0)
    spread = TwinSpread(optics, silhouette_for(UAV1), UAV1.small_m)
    size = UAV1.small_m / (range_m * sensor.ifov_rad)
    rng = np.random.default_rng(seed)
    frames, peaks = [], []
    for _ in range(n):
        frame = rng.standard_normal((40, 40))
        dx, dy = rng.uniform(-0.5, 0.5, 2)
        f = spread.fractions(dx, dy, size)
        h = (f.shape[0] - 1) // 2
        frame[20 - h : 21 + h, 20 - h : 21 + h] += amplitude * f
        r, c = np.unravel_index(int(np.argmax(frame[15:26, 15:26])), (11, 11))
        frames.append(frame)
        peaks.append((15 + c, 15 + r))
        if phases is not None:
            phases.append((20 + dx - (15 + c), 20 + dy - (15 + r)))
    return crop_frames(frames, peaks), size, optics.average_pvf()


@pytest.mark.parametrize(("camera", "range_m"), [("mwir", 451.0), ("lwir", 393.0)])
def test_the_fit_recovers_the_twins_pvf(camera, range_m):
    sensor = load_sensor(camera)
    crops, size, truth = _hover_crops(sensor, range_m)
    est = estimate_psf([StopCrops(f"{camera} {range_m}", crops, size)], sensor)
    assert est.n_frames == 120
    assert est.pvf == pytest.approx(truth, rel=0.05)
    assert 0 < est.pvf_std < 0.05 * est.pvf
    if camera == "mwir":
        assert est.sigma_px == pytest.approx(0.82, abs=0.04)
        # (the LWIR's sharp PSF at SNR ~300 sees the 1/12-px offset grid: chi2/dof ~12)
        assert est.chi2_per_dof["airy+gaussian"] < 2.0
    # the fitted PSF is a model PSF the corrected curve can take
    from snrmon.model.pvf import average_pvf

    # (est.pvf is interpolated on the fit's 0.1-px grid of blurs)
    assert average_pvf(est.psf(), sensor.fill_factor) == pytest.approx(est.pvf, rel=0.01)


def test_each_frames_phase_is_recovered_with_the_fitted_psf():
    """The phases a stop sampled (for the expected Eq. 4 over them): each frame's centroid
    offset from its peak pixel, on the fit's 1/12-px grid, at MWIR 451 m (SNR ~100)."""
    sensor = load_sensor("mwir")
    truth: list = []
    crops, size, _ = _hover_crops(sensor, 451.0, phases=truth)
    stop = StopCrops("mwir 451", crops, size)
    got = observed_phases(stop, estimate_psf([stop], sensor).psf(), sensor.fill_factor)
    err = np.abs(got - np.asarray(truth))
    assert got.shape == (120, 2)
    assert np.median(err) < 0.05  # the grid's half step is 0.042
    assert np.quantile(err, 0.95) < 0.12


def test_resolved_and_short_stops_are_refused_with_the_reason():
    sensor = load_sensor("mwir")
    crops, size, _ = _hover_crops(sensor, 451.0, n=30)
    with pytest.raises(PsfEstimateError, match=r"stop 2 .*resolved \(small dimension 1.58 px"):
        estimate_psf([StopCrops("stop 2 (mwir, 199 m)", crops, 1.58)], sensor)
    with pytest.raises(PsfEstimateError, match=r"stop 4 .*only 30 usable frames.*at least 50"):
        estimate_psf([StopCrops("stop 4 (mwir, 451 m)", crops, size)], sensor)
    with pytest.raises(PsfEstimateError, match="no stop"):
        estimate_psf([], sensor)


def test_crops_skip_frames_at_the_edge_and_apply_a_calibration():
    frames = [np.arange(400, dtype=float).reshape(20, 20)] * 2
    assert crop_frames(frames, [(10, 10), (2, 10)]).shape == (1, 13, 13)

    class Doubling:
        def correct(self, frame, window):
            r0, r1, c0, c1 = window
            return 2.0 * frame[r0:r1, c0:c1]

    out = crop_frames(frames[:1], [(10, 10)], Doubling())
    assert out[0, 6, 6] == 2.0 * frames[0][10, 10]


def test_snrmon_psf_refuses_a_resolved_stop_and_names_it(tmp_path, capsys):
    from snrmon.cli import main

    assert main(["psf", str(tmp_path / "none.h5"), "--camera", "mwir", "--stop", "0"]) != 0
    assert "none.h5" in capsys.readouterr().err
    _ = json  # the JSON contract is exercised on a recorded flight in tests/test_hil.py
