"""Radiometric calibration on simulated blackbody captures (sim's fixed pattern and noise, the
model's electrons; tests/acquisition/calibration_scene.py says why the scene is built here)."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.calibrate.calibration import (
    DEAD,
    HOT,
    NOISY,
    BlackbodyCapture,
    calibrate_sensor,
    radiance_of,
    temperature_of,
)
from snrmon.acquisition.calibrate.quality import calibration_quality
from tests.acquisition.calibration_scene import camera
from tests.helpers import strict_json

TEMPS_K = (283.15, 303.15, 318.15)


@pytest.fixture(scope="module")
def cam():
    return camera("mwir", shape=(96, 128), seed=3)


@pytest.fixture(scope="module")
def captures(cam):
    return [BlackbodyCapture(t, cam.blackbody(t, 32, seed=i)) for i, t in enumerate(TEMPS_K)]


@pytest.fixture(scope="module")
def cal(cam, captures):
    return calibrate_sensor(captures, cam.sensor)


def test_radiance_table_inverts_the_band_integral():
    band = (3.45, 5.25)
    t = np.array([200.0, 260.0, 300.0, 333.3, 450.0])
    assert np.allclose(temperature_of(band, radiance_of(band, t)), t, atol=2e-4)
    # same number as the model's Widger-Woodall band integral
    from snrmon.model.radiometry import band_photon_radiance

    assert radiance_of(band, 300.0) == pytest.approx(band_photon_radiance(band, 300.0), 1e-10)


def test_recovers_the_simulated_gain_and_offset_maps(cam, cal):
    # truth: DN = dn_offset + offset_map + gain_map * (k L + c) / G, so the fitted
    # responsivity is proportional to gain_map and the offset follows offset_map + gain_map c/G
    gain = cam.fpn.gain / cam.fpn.gain.mean()
    resp = cal.responsivity / cal.responsivity.mean()
    err = resp - gain
    assert np.std(err) < 0.15 * np.std(gain)
    assert np.corrcoef(gain.ravel(), resp.ravel())[0, 1] > 0.98
    # electrons are linear in L (lens emission and dark current: a constant pedestal c)
    t1, t2 = TEMPS_K[0], TEMPS_K[-1]
    l1, l2 = (float(radiance_of(cam.sensor.band_um, t)) for t in (t1, t2))
    k = (cam.electrons(t2) - cam.electrons(t1)) / (l2 - l1)
    c = cam.electrons(t1) - k * l1
    g_dn = cam.config.gain_e_per_dn
    truth_resp = cam.fpn.gain * k / g_dn
    truth_offset = cam.config.dn_offset + 0.5 + cam.fpn.offset_dn + cam.fpn.gain * c / g_dn
    assert np.median(cal.responsivity / truth_resp) == pytest.approx(1.0, abs=2e-3)
    off_err = cal.offset_dn - truth_offset
    assert abs(np.median(off_err)) < 2.0  # DN, at zero radiance (far extrapolation)
    assert np.std(off_err) < 0.3 * np.std(cam.fpn.offset_dn)
    assert not cal.bad.any()


def test_correction_removes_fpn_to_the_temporal_noise_floor(cam, cal):
    held_out = BlackbodyCapture(295.0, cam.blackbody(295.0, 32, seed=99))
    q = calibration_quality(cal, [held_out], cam.sensor.netd_mk)
    (row,) = q.temperatures
    assert row.raw_spatial_dn > 2.5 * row.temporal_noise_dn  # the FPN was there
    assert row.corrected_spatial_dn < 1.05 * row.temporal_noise_dn
    assert row.residual_fpn_mk < 0.3 * row.netd_mk
    # measured NETD = simulated temporal noise / true dDN/dT (model electrons per kelvin)
    de_dk = (cam.electrons(295.5) - cam.electrons(294.5)) / 1.0
    truth_mk = 1e3 * held_out_sigma(cam, 295.0) / (de_dk / cam.config.gain_e_per_dn)
    assert row.netd_mk == pytest.approx(truth_mk, rel=0.03)
    assert q.netd_table_mk == 41.0
    assert q.fit_rms_median_dn < held_out_sigma(cam, 300.0)


def held_out_sigma(cam, temp_k):
    c = cam.config
    return float(np.sqrt(c.floor_noise_e**2 + cam.electrons(temp_k)) / c.gain_e_per_dn)


def test_apparent_temperature_of_a_blackbody_within_0p1_k(cam, cal):
    for t in (290.0, 310.0):
        frames = cam.blackbody(t, 16, seed=int(t))
        t_app = cal.temperature_k(frames.mean(axis=0))
        assert abs(float(np.median(t_app)) - t) < 0.1
        assert abs(float(np.mean(cal.temperature_k(frames[0]))) - t) < 0.1


def test_two_points_give_the_same_line_and_zero_residual(cam, captures):
    two = calibrate_sensor(captures[::2], cam.sensor)
    assert not two.fit_rms_dn.any()
    frames = cam.blackbody(300.0, 16, seed=5)
    assert abs(float(np.median(two.temperature_k(frames.mean(0)))) - 300.0) < 0.1


def test_bad_pixels_dead_hot_noisy(cam):
    caps = []
    for i, t in enumerate(TEMPS_K):
        f = cam.blackbody(t, 24, seed=40 + i, noise_scale=_noise_scale(cam.shape)).astype(float)
        f[:, 10, 10] = f[:, 10, 10].mean() * 0 + 900.0  # dead: no response
        f[:, 20, 30] += 3000.0  # hot: a high pedestal
        caps.append(BlackbodyCapture(t, np.clip(f, 0, 16383).astype(np.uint16)))
    c = calibrate_sensor(caps, cam.sensor)
    assert c.bad[10, 10] & DEAD
    assert c.bad[20, 30] & HOT
    assert c.bad[40, 50] & NOISY
    assert np.count_nonzero(c.bad) == 3
    # bad pixels are filled from their neighbours in corrected frames
    t_app = c.temperature_k(cam.blackbody(300.0, 1, seed=1)[0])
    assert abs(t_app[10, 10] - 300.0) < 0.5


def _noise_scale(shape):
    s = np.ones(shape, np.float32)
    s[40, 50] = 8.0
    return s


def test_offset_update_from_a_shutter_restores_the_level(cam, cal):
    drifted = cam.blackbody(300.0, 8, seed=77).astype(np.int32) + 37  # the pedestal drifts
    before = float(np.median(cal.temperature_k(drifted.mean(0))))
    assert before - 300.0 > 0.1
    shutter = cam.blackbody(300.0, 8, seed=78).astype(np.int32) + 37
    updated = cal.with_offset_update(shutter, temp_k=300.0)
    scene = cam.blackbody(305.0, 8, seed=79).astype(np.int32) + 37
    assert abs(float(np.median(updated.temperature_k(scene.mean(0)))) - 305.0) < 0.1
    assert "shutter 300.00 K" in updated.offset_updates[-1]
    # a sky frame (unknown temperature) flattens a new offset pattern but keeps the level
    rng = np.random.default_rng(1)
    pattern = rng.normal(0, 20, cam.shape).astype(np.float32)
    sky = cam.blackbody(300.0, 8, seed=80) + pattern
    flat = cal.with_offset_update(sky)
    assert np.std(flat.correct(sky.mean(0))) < 0.5 * np.std(cal.correct(sky.mean(0)))


def test_saturated_capture_is_refused(cam):
    with pytest.raises(ValueError, match=r"capture at 60.00 C saturates: .*% of pixel values"):
        calibrate_sensor(
            [BlackbodyCapture(t, cam.blackbody(t, 4, seed=1)) for t in (293.15, 333.15)],
            cam.sensor,
        )


def test_too_few_temperatures_is_refused(cam):
    f = cam.blackbody(300.0, 4, seed=1)
    with pytest.raises(ValueError, match=r">= 2 distinct temperatures, got \[26.85\] C"):
        calibrate_sensor([BlackbodyCapture(300.0, f), BlackbodyCapture(300.0, f)], cam.sensor)
    with pytest.raises(ValueError, match="needs a stack of >= 2 frames"):
        calibrate_sensor([BlackbodyCapture(290.0, f[:1]), BlackbodyCapture(300.0, f)], cam.sensor)


def test_non_monotonic_response_is_refused(cam):
    hot, cold = cam.blackbody(310.0, 4, seed=1), cam.blackbody(290.0, 4, seed=2)
    with pytest.raises(ValueError, match="non-monotonic response: median DN does not rise"):
        calibrate_sensor([BlackbodyCapture(290.0, hot), BlackbodyCapture(310.0, cold)], cam.sensor)


def test_wrong_frame_size_is_refused(cal):
    with pytest.raises(ValueError, match=r"is for 128x96 frames, got 64x48"):
        cal.correct(np.zeros((48, 64), np.uint16))


def test_snrmon_calibrate_writes_the_file_and_reports(cam, tmp_path, capsys):
    from snrmon.cli import main

    for name, t in (("a", 288.15), ("b", 313.15)):
        np.save(tmp_path / f"{name}.npy", cam.blackbody(t, 8, seed=int(t)))
    out = tmp_path / "cal.npz"
    argv = ["calibrate", "--sensor", "mwir", "-o", str(out), "--json"]
    bb = ["--blackbody", f"{tmp_path / 'a.npy'}:15", "--blackbody", f"{tmp_path / 'b.npy'}:40"]
    assert main([*argv, *bb]) == 0
    report = strict_json(capsys.readouterr().out)
    assert out.is_file() and (tmp_path / "cal.toml").is_file()
    assert report["netd_table_mk"] == 41.0
    assert [round(r["temp_k"], 2) for r in report["temperatures"]] == [288.15, 313.15]
    for r in report["temperatures"]:  # each capture's 3D noise and the NETD from sigma_tvh
        assert set(r["noise_3d"]) == {
            "frames",
            "rows",
            "cols",
            "mean_dn",
            "sigma_dn",
            "sigma_corrected_dn",
            "ci95_dn",
        }
        assert r["netd_tvh_mk"] == pytest.approx(1e3 * r["sigma_tvh_dn"] / r["dn_per_k"])
    assert main([*argv[:-1], *bb]) == 0  # the table
    assert "NETD tvh" in capsys.readouterr().out
    assert main([*argv, *bb[:2]]) != 0
    assert ">= 2 distinct temperatures" in capsys.readouterr().err


def test_blackbody_3d_noise_and_the_netd_from_sigma_tvh(cam, cal, captures):
    q = calibration_quality(cal, captures)
    c = cam.config
    for r, cap in zip(q.temperatures, captures, strict=True):
        # the rendered temporal noise (sim: sqrt(floor^2 + electrons) / gain, white in t, v, h)
        # and the rounding to integers (1/12 DN^2) are sigma_tvh; 32 x 96 x 128 frames pin it
        # to 0.3 % (95 %), the 2 % here leaves room for the per-pixel gain map's spread
        e = cam.electrons(cap.temp_k)
        rendered = float(np.sqrt((c.floor_noise_e**2 + e) / c.gain_e_per_dn**2 + 1 / 12))
        assert r.sigma_tvh_dn == pytest.approx(rendered, rel=0.02)
        lo, hi = r.noise_3d["ci95_dn"]["tvh"]
        assert lo < r.sigma_tvh_dn < hi and hi - lo < 0.01 * r.sigma_tvh_dn
        assert r.netd_tvh_mk == pytest.approx(1e3 * r.sigma_tvh_dn / cal.dn_per_k(cap.temp_k))
        # sigma_vh is the camera's fixed pattern (offset and gain maps) at this level: the
        # pixel-to-pixel part of the noiseless image (0.7 % standard error here, 3 % allowed)
        static = cam.fpn.offset_dn + cam.fpn.gain * e / c.gain_e_per_dn
        vh = static - static.mean(0) - static.mean(1, keepdims=True) + static.mean()
        pattern = float(np.sqrt(np.sum(vh**2) / ((cam.shape[0] - 1) * (cam.shape[1] - 1))))
        assert r.noise_3d["sigma_corrected_dn"]["vh"] == pytest.approx(pattern, rel=0.03)
        assert r.noise_3d["frames"] == 32 and (r.noise_3d["rows"], r.noise_3d["cols"]) == cam.shape


def test_snrmon_noise_gives_netd_with_the_calibration(cam, cal, tmp_path, capsys):
    from snrmon.acquisition.calibrate.calibration_file import save_calibration
    from snrmon.cli import main

    path = save_calibration(cal, tmp_path / "cal.npz")
    frames = cam.blackbody(303.15, 32, seed=11)
    np.save(tmp_path / "bb.npy", frames)
    assert main(["noise", str(tmp_path / "bb.npy"), "--calibration", str(path), "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    q = calibration_quality(cal, [BlackbodyCapture(303.15, frames)]).temperatures[0]
    assert out["sigma_corrected_dn"] == q.noise_3d["sigma_corrected_dn"]
    assert out["scene_temp_k"] == pytest.approx(303.15, abs=0.1)  # the apparent temperature
    assert out["netd_mk"] == pytest.approx(q.netd_tvh_mk, rel=1e-3)  # SiTF at 303.15 K +/- 0.1
    assert out["sigma_corrected_k"]["tvh"] * out["sitf_dn_per_k"] == pytest.approx(
        out["sigma_corrected_dn"]["tvh"]
    )
    lo, hi = out["netd_ci95_mk"]
    assert lo < out["netd_mk"] < hi
    assert main(["noise", str(tmp_path / "bb.npy"), "--calibration", str(path)]) == 0
    text = capsys.readouterr().out
    assert "NETD = sigma_tvh / SiTF" in text and "[mK]" in text
