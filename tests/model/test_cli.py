"""``snrmon model``: JSON contracts and one-line errors."""

from pathlib import Path

import pytest

from snrmon.cli import main
from snrmon.model.modtran import read_tape7
from snrmon.model.presets import load_sensor
from tests.helpers import strict_json
from tests.model.growth_reference import moved_reference
from tests.model.test_modtran_tape7 import trapezoid_mean

FIX = Path(__file__).with_name("fixtures")


def _run(capsys, *argv):
    try:
        code = main(["model", *argv])
    except SystemExit as exc:  # refused by the parser (a value out of its option's range)
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_snr_json(capsys):
    code, out, _ = _run(
        capsys,
        "snr",
        "--sensor",
        "mwir",
        "--target",
        "uav1",
        "--ranges",
        "37,126,199,336,393,451,508",
        "--json",
    )
    assert code == 0
    recs = strict_json(out)
    assert [r["range_m"] for r in recs] == [37, 126, 199, 336, 393, 451, 508]
    assert recs[3]["resolved_small"] is False and recs[3]["resolved_large"] is True
    assert recs[6]["snr_small_corrected"] < recs[6]["snr_small"]
    assert set(recs[0]["noise_e"]) == {"background", "lens", "dark", "read", "temporal", "spatial"}
    assert 0.6 < recs[6]["transmission"] < 0.7


def test_snr_with_background_and_modtran_file(capsys):
    tape = str(FIX / "tape7_radiance.txt")
    code, out, _ = _run(
        capsys,
        "snr",
        "--sensor",
        "lwir",
        "--target",
        "uav2",
        "--ranges",
        "393",
        "--atmosphere",
        tape,
        "--atmosphere-path-m",
        "1000",
        "--sky-temp-c",
        "29.5",
        "--json",
    )
    assert code == 0
    rec = strict_json(out)[0]
    # the flat 0.7 of 1000 m moved to 393 m along the curve of growth, over the band
    sp = read_tape7(tape, 1000.0)
    band = load_sensor("lwir").band_um
    moved = moved_reference(sp.wavelength_um, sp.transmission, 1000.0, 393.0)
    flat = trapezoid_mean(sp.wavelength_um, moved, *band)
    assert rec["transmission"] == pytest.approx(flat, rel=2e-3)
    assert rec["transmission"] < 0.7 ** (393 / 1000) - 0.01  # not Beer-Lambert per sample


def test_pvf_radiance_netd_json(capsys):
    code, out, _ = _run(
        capsys,
        "pvf",
        "--psf",
        "airy",
        "--f-number",
        "1.25",
        "--pitch-um",
        "17",
        "--wavelength-um",
        "10",
        "--fill-factor",
        "0.9",
        "--json",
    )
    assert code == 0 and strict_json(out)["average_pvf"] == pytest.approx(0.4654, abs=5e-4)
    code, out, _ = _run(
        capsys,
        "pvf",
        "--psf",
        "gaussian",
        "--sigma-px",
        "0.8",
        "--fill-factor",
        "0.8",
        "--target-size-px",
        "1",
        "--json",
    )
    assert strict_json(out)["average_pvf"] == pytest.approx(0.1602 * 0.762, abs=2e-3)
    code, out, _ = _run(capsys, "radiance", "--band", "8,12", "--temp-k", "300", "--json")
    r = strict_json(out)
    assert r["radiance_w_m2_sr"] == pytest.approx(38.50042, rel=1e-6)
    assert set(r) == {
        "radiance_w_m2_sr",
        "photon_radiance",
        "d_radiance_dt",
        "d_photon_radiance_dt",
    }
    code, out, _ = _run(capsys, "netd", "--sensor", "mwir", "--json")
    n = strict_json(out)
    assert abs(n["netd_mk"] / 41 - 1) < 0.2 and n["temporal_noise_dn"] == pytest.approx(
        6.6, rel=0.05
    )


def test_plot_writes_a_png(capsys, tmp_path):
    png = tmp_path / "fig.png"
    code, _, _ = _run(capsys, "plot", "--sensor", "lwir", "--target", "uav1", "-o", str(png))
    assert code == 0 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["snr", "--sensor", "swir", "--target", "uav1"], "unknown sensor 'swir'"),
        (["snr", "--sensor", "mwir", "--target", "uav7"], "unknown target 'uav7'"),
        (["snr", "--sensor", "mwir", "--target", "uav1", "--ranges", "100,-3"], "-3"),
        (["radiance", "--band", "12,8", "--temp-k", "300"], "--band"),
        (["pvf", "--psf", "airy", "--f-number", "2"], "--pitch-um"),
        (["snr", "--sensor", "mwir", "--target", "uav1", "--atmosphere", "BAD_TAPE7"], "-9999"),
        (["snr", "--sensor", "BAD_TOML", "--target", "uav1"], "malformed TOML"),
        (["snr", "--sensor", "SWIR_TOML", "--target", "uav1"], "outside the built-in"),
    ],
)
def test_bad_input_is_one_line(capsys, tmp_path, argv, needle):
    tape = tmp_path / "bad.tp7"
    tape.write_text(" FREQ TOT_TRANS\n 2000.0 0.5\n")
    toml = tmp_path / "bad.toml"
    toml.write_text("[sensor\n")
    swir = tmp_path / "swir.toml"
    text = (Path(__file__).parents[2] / "model" / "presets" / "mwir.toml").read_text()
    swir.write_text(text.replace("band_um = [3.45, 5.25]", "band_um = [1.0, 1.7]"))
    subst = {"BAD_TAPE7": str(tape), "BAD_TOML": str(toml), "SWIR_TOML": str(swir)}
    argv = [subst.get(a, a) for a in argv]
    argv += ["--atmosphere-path-m", "100"] if "BAD_TAPE7" in str(argv) or str(tape) in argv else []
    code, out, err = _run(capsys, *argv)
    assert code != 0 and out == ""
    assert len(err.strip().splitlines()) == 1 and needle in err


def _snr(capsys, *argv):
    code, out, err = _run(capsys, "snr", "--target", "uav1", "--json", *argv)
    assert code == 0, err
    return strict_json(out)


def test_met_readings_drive_the_transmission(capsys):
    """--rh 20 against --rh 90 at 500 m, air 20 C: both bands lose transmission (LOWTRAN7's
    amount: tests/model/test_atmosphere_lowtran.py), and the signal with it."""
    for sensor, drop in (("lwir", 0.10), ("mwir", 0.08)):
        dry, humid = (
            _snr(capsys, "--sensor", sensor, "--ranges", "500", "--air-temp-c", "20", "--rh", rh)[0]
            for rh in ("20", "90")
        )
        assert humid["transmission"] < dry["transmission"] - drop
        assert humid["transmission_contrast"] < dry["transmission_contrast"] - drop
        assert humid["snr_small_corrected"] < dry["snr_small_corrected"]
        assert dry["air_temp_k"] == pytest.approx(293.15)
    # the same RH as a dew point; haze and pressure lower it further
    base = ("--sensor", "lwir", "--ranges", "2000", "--air-temp-c", "20")
    rh = _snr(capsys, *base, "--rh", "52.7")[0]["transmission"]
    td = _snr(capsys, *base, "--dew-point-c", "10")[0]["transmission"]
    assert td == pytest.approx(rh, abs=2e-3)
    hazy = _snr(capsys, *base, "--rh", "52.7", "--visibility-km", "5")[0]["transmission"]
    assert hazy < rh - 0.02
    tropical = _snr(capsys, "--sensor", "lwir", "--ranges", "2000", "--season", "tropical")[0]
    assert tropical["air_temp_k"] == pytest.approx(299.7) and tropical["transmission"] < rh


def test_sky_assumed_or_measured_is_said(capsys):
    assumed = _snr(capsys, "--sensor", "mwir", "--ranges", "508")[0]
    assert assumed["sky_assumed_equal_to_air"] is True
    assert assumed["sky_temp_k"] == assumed["air_temp_k"]
    measured = _snr(capsys, "--sensor", "mwir", "--ranges", "508", "--sky-temp-c", "5")[0]
    assert measured["sky_assumed_equal_to_air"] is False
    assert measured["sky_temp_k"] == pytest.approx(278.15)
    lo, hi = assumed["uncertainty"]["small_corrected"]
    lo_m, hi_m = measured["uncertainty"]["small_corrected"]
    assert (hi - lo) / assumed["snr_small_corrected"] > 2 * (hi_m - lo_m) / measured[
        "snr_small_corrected"
    ]


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--rh", "120"], "relative humidity must be 0 to 100 %, got 120"),
        (["--air-temp-c", "70"], "air temperature must be -30 to 45 C, got 70"),
        (["--pressure-hpa", "500"], "pressure must be 700 to 1060 hPa, got 500"),
        (["--visibility-km", "0"], "visibility must be 0.5 to 300 km, got 0"),
        (["--air-temp-c", "10", "--dew-point-c", "15"], "dew point 15 C is above the air"),
        (["--atmosphere", "none", "--rh", "50"], "--rh sets the built-in LOWTRAN7 atmosphere"),
    ],
)
def test_bad_met_readings_are_one_line(capsys, argv, needle):
    code, out, err = _run(capsys, "snr", "--sensor", "mwir", "--target", "uav1", *argv)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], err


def test_lwir_papers_corrected_curve_is_not_the_uncorrected_one(capsys):
    code, out, _ = _run(
        capsys,
        "snr",
        "--sensor",
        "lwir",
        "--target",
        "uav1",
        "--ranges",
        "199",
        "--atmosphere",
        "none",
        "--json",
    )
    assert code == 0
    (rec,) = strict_json(out)
    paper = rec["snr_paper"]
    # the finite-size correction (sigma_t = D/2 at D = 0.78 px) and the LWIR's blur: -36 %
    assert paper["small_corrected"] / paper["small"] == pytest.approx(0.635, abs=0.01)
