"""Presets and Eq. 1: NETD within 20 % of Table 1, temporal noise near the paper's DN values,
an independent worked example, and TOML validation."""

import dataclasses

import pytest

from snrmon.model.detector import (
    background_electrons,
    dark_electrons,
    lens_electrons,
    scene_electrons,
)
from snrmon.model.noise import model_netd_mk, noise_breakdown, spatial_noise_e, temporal_noise_e
from snrmon.model.presets import load_sensor, load_target


@pytest.mark.parametrize(("name", "netd_mk", "dn"), [("mwir", 41.0, 6.6), ("lwir", 50.0, 5.8)])
def test_presets_match_table1_netd_and_section6_noise(name, netd_mk, dn):
    s = load_sensor(name)
    assert s.netd_mk == netd_mk
    assert abs(model_netd_mk(s) / netd_mk - 1.0) < 0.2
    assert temporal_noise_e(s, 290.0) / s.gain_e_per_dn == pytest.approx(dn, rel=0.05)
    # a 290 K sky sits inside the 14-bit range with room for the target
    level = s.dn_offset + background_electrons(s, 290.0) / s.gain_e_per_dn
    assert 1000 < level < 0.6 * s.full_scale_dn


def test_table1_geometry():
    mw, lw = load_sensor("mwir"), load_sensor("lwir")
    assert mw.ifov_rad == pytest.approx(0.5e-3)
    assert mw.f_lambda_over_d == pytest.approx(1.25, abs=0.01)
    assert lw.f_lambda_over_d == pytest.approx(0.735, abs=0.01)
    assert mw.aperture_diameter_m == pytest.approx(0.016 / 2.3)
    assert (mw.width_px, mw.height_px, lw.width_px, lw.height_px) == (1280, 720, 640, 480)


def test_physics_notes_worked_example():
    # the worked example: QE 0.6, tau_o 0.8, tau_cf 0.9, 5 ms, 293 K lens eps 0.2, 1e-7 A/cm2, 100
    # e-
    s = dataclasses.replace(load_sensor("mwir"), t_int_s=0.005, lens_temp_k=293.0)
    assert scene_electrons(s, 290.0) == pytest.approx(6.57e5, rel=5e-3)
    assert lens_electrons(s) == pytest.approx(1.83e5, rel=1e-2)
    assert dark_electrons(s) == pytest.approx(1.6e3, rel=1e-2)
    assert temporal_noise_e(s, 290.0) == pytest.approx(923.0, rel=2e-3)


def test_eq1_is_the_quadrature_sum_and_bolometer_noise_is_from_netd():
    nb = noise_breakdown(load_sensor("mwir"), 280.0)
    assert nb.temporal == pytest.approx(
        (nb.background**2 + nb.lens**2 + nb.dark**2 + 100.0**2) ** 0.5
    )
    lw = load_sensor("lwir")
    nb = noise_breakdown(lw, 290.0)
    assert nb.dark == 0.0 and nb.read > 10 * nb.background
    assert model_netd_mk(lw) == pytest.approx(50.0, rel=1e-9)  # by construction


def test_spatial_noise_specs():
    assert spatial_noise_e(None, 10.0) == 0.0
    assert spatial_noise_e("medium", 10.0) == 25.0
    assert spatial_noise_e("2x", 10.0) == 20.0
    assert spatial_noise_e(7.0, 10.0) == 7.0
    with pytest.raises(ValueError, match=r"clutter|spatial"):
        spatial_noise_e("lots", 10.0)


def test_targets_from_section3():
    u1, u2 = load_target("uav1"), load_target("uav2")
    assert (u1.small_m, u1.large_m, u2.small_m, u2.large_m) == (0.157, 0.238, 0.201, 0.367)
    assert u1.temp_k("mwir") == pytest.approx(309.85) and u1.temp_k("lwir") == pytest.approx(308.35)
    assert u2.temp_c == {"mwir": 39.1, "lwir": 43.8}
    assert u1.rss_delta_t_k["lwir"] == 1.44


def test_unknown_presets_and_bad_toml(tmp_path):
    with pytest.raises(ValueError, match=r"unknown sensor 'swir'.*mwir, lwir"):
        load_sensor("swir")
    with pytest.raises(ValueError, match=r"unknown target 'uav9'.*uav1, uav2"):
        load_target("uav9")
    bad = tmp_path / "s.toml"
    bad.write_text("[sensor\nname = 1\n")
    with pytest.raises(ValueError, match="malformed TOML"):
        load_sensor(str(bad))
    text = (load_sensor.__globals__["PRESET_DIR"] / "mwir.toml").read_text()
    bad.write_text(text.replace("fill_factor = 0.8 ", "fill_factor = 80 "))
    with pytest.raises(
        ValueError, match=r"\[sensor\] fill_factor = 80: expected a number in \(0, 1\]"
    ):
        load_sensor(str(bad))
    bad.write_text(text.replace("pitch_um = 8.0", "pitch_mm = 8.0"))
    with pytest.raises(ValueError, match="unknown key 'pitch_mm'"):
        load_sensor(str(bad))
    ok = tmp_path / "mine.toml"
    ok.write_text(text.replace('name = "mwir"', 'name = "mine"'))
    assert load_sensor(str(ok)).name == "mine"
