"""Pointing calibration recovers a known pointing from seeded noisy (pixel, GPS) pairs."""

from __future__ import annotations

import math

import numpy as np
import pymap3d
import pytest

from snrmon.acquisition.geo.pointing import calibrate_pointing
from snrmon.acquisition.geo.projection import (
    CameraIntrinsics,
    Pointing,
    Site,
    camera_axes,
    project_to_pixel,
)
from snrmon.cli import main
from tests.helpers import strict_json

SITE = Site(32.38, -106.48, 1200.0)
MWIR = CameraIntrinsics(0.016, 8e-6, 1280, 720)


def _pairs(truth: Pointing, n: int, noise_px: float, seed: int):
    """Close-range GPS positions spread over the field of view (30-80 m, +-14 deg across,
    +-8 deg up), their true pixels plus Gaussian tracking noise."""
    rng = np.random.default_rng(seed)
    r, u, f = camera_axes(*np.radians([truth.az_deg, truth.el_deg, truth.roll_deg]))
    pairs = []
    while len(pairs) < n:
        a, b = np.tan(np.radians([rng.uniform(-14, 14), rng.uniform(-8, 8)]))
        enu = rng.uniform(30, 80) * (f + a * r + b * u)
        lat, lon, alt = pymap3d.enu2geodetic(*enu, SITE.lat_deg, SITE.lon_deg, SITE.alt_m)
        p = project_to_pixel(SITE, truth, MWIR, lat, lon, alt)
        assert p.in_view
        x, y = p.x + rng.normal(0, noise_px), p.y + rng.normal(0, noise_px)
        pairs.append((x, y, float(lat), float(lon), float(alt)))
    return pairs


@pytest.mark.parametrize(
    "truth", [Pointing(40.0, 8.0, 0.0), Pointing(312.5, 3.2, -7.5), Pointing(0.4, 25.0, 12.0)]
)
def test_recovers_known_pointing_from_noisy_pairs(truth):
    fit = calibrate_pointing(_pairs(truth, 8, 1.0, seed=7), SITE, MWIR)
    # 1 px of tracking noise at 2000 px/rad over 8 pairs: the axis to ~0.02 deg; roll (lever
    # arm ~200 px) to ~0.3 deg. Tolerances are 3x those.
    az_err = (fit.az_deg - truth.az_deg + 180.0) % 360.0 - 180.0
    assert abs(az_err) < 0.06
    assert fit.el_deg == pytest.approx(truth.el_deg, abs=0.06)
    assert fit.roll_deg == pytest.approx(truth.roll_deg, abs=1.0)
    # The residual is the tracking noise: rms of a 2-D Gaussian of 1 px per axis ~ sqrt(2) px,
    # less what the three fitted angles absorb.
    assert 0.5 < fit.residual_px_rms < 2.2
    assert fit.residual_px_max >= fit.residual_px_rms
    assert fit.n_pairs == 8 and len(fit.residuals_px) == 8


def test_exact_pairs_give_zero_residual_from_a_distant_start():
    truth = Pointing(123.0, 10.0, 4.0)
    fit = calibrate_pointing(_pairs(truth, 3, 0.0, seed=1), SITE, MWIR, Pointing(110, 5, 0))
    assert fit.residual_px_rms < 1e-6
    assert (fit.az_deg, fit.el_deg, fit.roll_deg) == (
        pytest.approx(123.0, abs=1e-7),
        pytest.approx(10.0, abs=1e-7),
        pytest.approx(4.0, abs=1e-7),
    )


def test_a_wrong_pair_shows_in_the_residual():
    pairs = _pairs(Pointing(40.0, 8.0, 0.0), 6, 0.0, seed=3)
    x, y, *geo = pairs[2]
    pairs[2] = (x + 40.0, y, *geo)  # a mis-clicked pair
    fit = calibrate_pointing(pairs, SITE, MWIR)
    assert fit.residual_px_max > 20.0
    assert int(np.argmax(fit.residuals_px)) == 2


def test_fewer_than_three_pairs_is_a_clear_error():
    pairs = _pairs(Pointing(40.0, 8.0, 0.0), 2, 0.0, seed=0)
    with pytest.raises(ValueError, match="at least 3"):
        calibrate_pointing(pairs, SITE, MWIR)
    with pytest.raises(ValueError, match="pair 1"):
        calibrate_pointing([pairs[0], (1.0, math.nan, 0, 0, 0), pairs[1]], SITE, MWIR)


def test_cli_geo_calibrate(tmp_path, capsys):
    truth = Pointing(40.0, 8.0, 2.0)
    path = tmp_path / "pairs.csv"
    rows = ["x_px,y_px,lat_deg,lon_deg,alt_m"]
    rows += [",".join(repr(v) for v in p) for p in _pairs(truth, 5, 0.3, seed=11)]
    path.write_text("\n".join(rows) + "\n")
    code = main(
        [
            "geo",
            "calibrate",
            "--pairs",
            str(path),
            "--site",
            "32.38,-106.48,1200",
            "--intrinsics",
            "0.016,8,1280,720",
            "--json",
        ]
    )
    assert code == 0
    out = strict_json(capsys.readouterr().out)
    assert out["az_deg"] == pytest.approx(40.0, abs=0.05)
    assert out["el_deg"] == pytest.approx(8.0, abs=0.05)
    assert out["n_pairs"] == 5 and out["residual_px_rms"] < 1.0
