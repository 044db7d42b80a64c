"""``snrmon report`` on a simulated session: the CSV's columns and values, Fig. 6/12 data, the 3D
noise of each stop's background and the model with the measured noise, and the PDF and PNG
renderings."""

from __future__ import annotations

import csv
import math

import cv2
import numpy as np
import pytest

from snrmon.acquisition.prediction import (
    BANDED_CURVES,
    CURVES,
    STOP_EXPECTED_CURVES,
    ModelPredictor,
)
from snrmon.acquisition.report.data import BUDGET_TERMS, report_data, rows_sky_k
from snrmon.acquisition.report.plot import PAGE_IN, PNG_DPI
from snrmon.acquisition.report.stop_csv import CSV_COLUMNS
from snrmon.cli import main
from tests.acquisition.session_factory import SPOT_XY, write_session

RANGES_M = (120.0, 240.0)


@pytest.fixture(scope="module")
def session(module_tmp):
    return write_session(module_tmp("report") / "s.h5", ranges_m=RANGES_M)


@pytest.fixture(scope="module")
def data(session):
    return report_data(session.path)


@pytest.fixture(scope="module")
def outputs(session, module_tmp):
    out = module_tmp("out")
    pdf, png, table = out / "r.pdf", out / "r.png", out / "t.csv"
    assert main(["report", str(session.path), "-o", str(pdf), "--csv", str(table)]) == 0
    assert (
        main(["report", str(session.path), "-o", str(png), "--quiet", "--noise", "measured"]) == 0
    )
    with table.open(newline="") as fh:
        rows = list(csv.reader(fh))
    return pdf, png, rows


def _eq4(frame: np.ndarray) -> tuple[float, float, float, float]:
    """Eq. 4 written out: brightest pixel of the 11x11 window at the spot, 7x7 box rim."""
    x0, y0 = SPOT_XY
    win = frame[y0 - 5 : y0 + 6, x0 - 5 : x0 + 6].astype(float)
    dy, dx = np.unravel_index(np.argmax(win), win.shape)
    y, x = y0 - 5 + dy, x0 - 5 + dx
    box = frame[y - 3 : y + 4, x - 3 : x + 4].astype(float)
    rim = np.concatenate([box[0], box[-1], box[1:-1, 0], box[1:-1, -1]])
    assert rim.size == 24
    return (
        float(frame[y, x]),
        rim.mean(),
        rim.std(ddof=1),
        (frame[y, x] - rim.mean()) / rim.std(ddof=1),
    )


@pytest.mark.slow
def test_csv_has_exactly_the_columns(outputs):
    _, _, rows = outputs
    assert tuple(rows[0]) == CSV_COLUMNS
    # the stop table's columns, by the names of Session.stops() and the campaign's Parquet
    assert CSV_COLUMNS[:12] == (
        "camera",
        "stop",
        "manual",
        "t_start_utc",
        "t_end_utc",
        "range_m",
        "lrf_range_m",
        "gps_range_m",
        "n_frames",
        "complete",
        "snr_mean",
        "snr_std",
    )
    bands = [f"model_{c}_{e}" for c in BANDED_CURVES for e in ("lower", "upper")]
    assert [c for c in CSV_COLUMNS if c.startswith("model_")] == [
        "model_resolved_small",
        "model_sky_temp_k",
        *(f"model_{c}" for c in CURVES),
        "model_expected_eq4_rim",
        "model_expected_eq4_extent",
        *bands,
        # over the stop's own sub-pixel phases, where a row has them (a fitted PSF, unresolved)
        *(f"model_{c}{s}" for c in STOP_EXPECTED_CURVES for s in ("", "_lower", "_upper")),
    ]
    assert [c for c in CSV_COLUMNS if c.startswith("ratio_")] == [
        *(f"ratio_{c}" for c in CURVES),
        "ratio_expected_eq4",
    ]
    # the stop's times in UTC (ISO 8601) from the session's clock
    assert all(r[3].startswith("20") and r[3].endswith("Z") for r in rows[1:])
    # Two planned stops x two cameras.
    assert sorted((r[0], r[1]) for r in rows[1:]) == [
        ("lwir", "0"),
        ("lwir", "1"),
        ("mwir", "0"),
        ("mwir", "1"),
    ]


def test_csv_values_match_an_independent_computation(session, data, outputs):
    _, _, rows = outputs
    header = rows[0]
    predictor = ModelPredictor({"mwir": "mwir", "lwir": "lwir"}, "uav1")
    t_start = {(r.camera, r.stop): r.place.t_start_ns for r in data.flight.rows}
    for values in rows[1:]:
        row = dict(zip(header, values, strict=True))
        cam, stop = row["camera"], int(row["stop"])
        lrf = float(row["lrf_range_m"])
        assert lrf == pytest.approx(RANGES_M[stop], abs=0.15)  # median of 0.1 m noisy shots
        assert int(row["n_frames"]) == 100
        first = int(np.searchsorted(session.frame_t_ns, t_start[(cam, stop)]))
        snr = np.array([_eq4(f)[3] for f in session.frames[cam][first : first + 100]])
        assert float(row["snr_mean"]) == pytest.approx(snr.mean(), rel=1e-12)
        assert float(row["snr_std"]) == pytest.approx(snr.std(ddof=1), rel=1e-12)
        model = predictor(cam, lrf)
        for c in CURVES:
            assert float(row[f"model_{c}"]) == pytest.approx(model[c], rel=1e-12)
            assert float(row[f"ratio_{c}"]) == pytest.approx(snr.mean() / model[c], rel=1e-12)
        # both expected Eq. (4) readings, and the one this stop's background (the compact
        # spot's 7x7 rim: the paper's Eq. 4) makes applicable
        assert (row["background"], row["expected_eq4_rule"]) == ("rim", "rim")
        for c in ("expected_eq4_rim", "expected_eq4_extent"):
            assert float(row[f"model_{c}"]) == pytest.approx(model[c], rel=1e-12)
        rim = model["expected_eq4_rim"]
        assert float(row["ratio_expected_eq4"]) == pytest.approx(snr.mean() / rim, rel=1e-12)
    # The synthetic spot falls as 1/R^2: 4x the contrast at half the range.
    snr_mean = CSV_COLUMNS.index("snr_mean")
    means = {(r[0], r[1]): float(r[snr_mean]) for r in rows[1:]}
    assert 3.0 < means[("mwir", "0")] / means[("mwir", "1")] < 5.0


def test_3d_noise_of_each_stops_background(session, data):
    """Per stop and camera: the stop's 100 summary frames, the largest region clear of the spot by
    20 px, and its 3D noise is that of those pixels of the file."""
    from snrmon.acquisition.measure.noise3d import noise_3d

    assert sorted((s.stop, s.camera) for s in data.flight.noise_3d) == sorted(
        (r.stop, r.camera) for r in data.flight.rows
    )
    start = {(r.camera, r.stop): r.place.t_start_ns for r in data.flight.rows}
    for s in data.flight.noise_3d:
        first = int(np.searchsorted(session.frame_t_ns, start[(s.camera, s.stop)]))
        assert s.frames == (first, first + 99)
        x0, y0, x1, y1 = s.region
        assert x1 < SPOT_XY[0] - 20 or x0 > SPOT_XY[0] + 20 or y1 < SPOT_XY[1] - 20
        want = noise_3d(session.frames[s.camera][first : first + 100, y0 : y1 + 1, x0 : x1 + 1])
        assert s.noise.sigma_corrected == want.sigma_corrected
        # the sky is white noise of 5 DN, rounded: all of it is sigma_tvh (>= 20000 values:
        # 0.5 % standard error, 3 % allowed)
        assert s.noise.sigma_corrected["tvh"] == pytest.approx((25 + 1 / 12) ** 0.5, rel=0.03)


@pytest.fixture(scope="module")
def measured(session):
    return report_data(session.path, noise="measured")


def test_measured_noise_replaces_the_models_noise(data, measured):
    """With the operator's "measured noise" every model value is the model's own times its noise
    over the camera's measured sqrt(sigma_tvh^2 + sigma_vh^2) (Eq. 3's denominator)."""
    from snrmon.model.noise import noise_breakdown
    from snrmon.model.presets import load_sensor

    for cam, m in measured.measured_noise.items():
        mine = [s.noise.sigma_corrected for s in data.flight.noise_3d if s.camera == cam]
        assert m.temporal_dn == pytest.approx(math.sqrt(np.mean([x["tvh"] ** 2 for x in mine])))
        assert m.spatial_dn == pytest.approx(math.sqrt(np.mean([x["vh"] ** 2 for x in mine])))
    own = {(r.camera, r.stop): r for r in data.flight.rows}
    for row in measured.flight.rows:
        base = own[(row.camera, row.stop)]
        assert row.reading.snr_mean == base.reading.snr_mean  # the measurement is the same
        sensor = load_sensor(row.camera)
        model_e = noise_breakdown(sensor, row.model.model_sky_temp_k).total
        measured_e = measured.measured_noise[row.camera].total_dn * sensor.gain_e_per_dn
        for c in CURVES:
            assert row.model.model_snr[c] == pytest.approx(
                base.model.model_snr[c] * model_e / measured_e, rel=1e-3
            )
    for cam, curves in measured.model.curves.items():
        sensor = load_sensor(cam)
        ratio = noise_breakdown(sensor, curves.background_temp_k).total / (
            measured.measured_noise[cam].total_dn * sensor.gain_e_per_dn
        )
        np.testing.assert_allclose(curves.snr["small"], data.model.curves[cam].snr["small"] * ratio)


def test_csv_gps_range_is_the_planned_range(outputs):
    _, _, rows = outputs
    gps = CSV_COLUMNS.index("gps_range_m")
    for values in rows[1:]:
        assert values[gps] != "" and float(values[gps]) == pytest.approx(
            RANGES_M[int(values[1])], abs=0.5
        )


def test_fig6_series_are_the_stop_summary_frames(session, data):
    assert len(data.flight.series) == 4
    by_key = {(r.camera, r.stop): r for r in data.flight.rows}
    for s in data.flight.series:
        row = by_key[(s.camera, s.stop)]
        assert len(s.snr) == len(s.peak) == len(s.bg_mean) == len(s.bg_std) == 100
        assert s.snr.mean() == pytest.approx(row.reading.snr_mean, rel=1e-12)
        assert np.all(np.diff(s.t_s) > 0) and s.t_s[0] >= 0
        first = int(np.searchsorted(session.frame_t_ns, row.place.t_start_ns))
        expect = np.array([_eq4(f) for f in session.frames[s.camera][first : first + 100]])
        np.testing.assert_allclose(s.peak, expect[:, 0], rtol=0, atol=0)
        np.testing.assert_allclose(s.bg_mean, expect[:, 1], rtol=1e-12)
        np.testing.assert_allclose(s.bg_std, expect[:, 2], rtol=1e-12)


def test_budget_and_curves_are_the_models(data):
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    for cam, budgets in data.model.budgets.items():
        assert [b.range_m for b in budgets] == sorted(
            r.range_m for r in data.flight.rows if r.camera == cam
        )
        # at the sky the rows' model values were computed for (the budget's path term)
        p = predict(
            load_sensor(cam),
            load_target("uav1"),
            [b.range_m for b in budgets],
            background_temp_k=rows_sky_k(data.flight.rows, cam),
        )
        for i, b in enumerate(budgets):
            assert tuple(b.terms) == BUDGET_TERMS
            assert b.total == pytest.approx(p.relative_uncertainty["small_corrected"][i], rel=1e-12)
            assert b.total == pytest.approx(
                math.sqrt(sum(v**2 for v in b.terms.values())), rel=1e-12
            )
            assert b.resolved == bool(p.resolved_small[i])
        m = data.model.curves[cam]
        assert m.transition_small_m == pytest.approx(p.transition_range_small_m)
        assert m.ranges_m[0] <= min(RANGES_M) and m.ranges_m[-1] >= max(RANGES_M)
    # Points for the Figs. 7-10 markers: one per stop, error bar = the stop's std.
    pts = data.flight.points["lwir"]
    assert pts.range_m.tolist() == pytest.approx(list(RANGES_M), abs=0.15)
    assert np.all(pts.snr_std > 0)
    assert np.all(pts.snr_sem > 0)


def test_pdf_and_png_render(outputs):
    pdf, png, _ = outputs
    head = pdf.read_bytes()
    assert head[:5] == b"%PDF-" and len(head) > 20_000
    # summary, 3D noise, one Figs. 7-10 page for two cameras, the paper's numbers and Pd,
    # Fig. 12, one Fig. 6 page per stop
    assert b"/Count 7" in head
    img = cv2.imread(str(png))
    assert img is not None
    page_h, page_w = round(PAGE_IN[1] * PNG_DPI), round(PAGE_IN[0] * PNG_DPI)
    assert img.shape == (7 * page_h, page_w, 3)
    assert img.std() > 10  # drawn, not blank


def test_missing_file_and_bad_output_are_one_line_errors(tmp_path, session, capsys):
    assert main(["report", str(tmp_path / "none.h5"), "-o", str(tmp_path / "r.pdf")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "none.h5" in err[0] and "does not exist" in err[0]
    assert main(["report", str(session.path), "-o", str(tmp_path / "r.svg")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ".pdf or .png" in err[0]
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not hdf5")
    assert main(["report", str(junk), "-o", str(tmp_path / "r.pdf")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "junk.h5" in err[0]


def test_report_compares_the_stops_and_the_paper(data):
    """chi2/dof per curve of the unresolved stops, the paper's reference numbers beside ours
    with a reason each, and Pd versus range with the detection range's confidence."""
    refs = {r.quantity: r for r in data.model.references}
    assert refs["MWIR average PVF, diffraction limited"].paper == "0.25"
    assert refs["MWIR average PVF, diffraction limited"].ours == "0.2414"
    assert refs["NETD MWIR / LWIR (mK)"].ours == "41.1 / 50.0"
    assert all(r.reason for r in data.model.references) and len(data.model.references) == 6
    for cam, d in data.model.detections.items():
        assert d.range_lower_m < d.range_m < d.range_upper_m, cam
    curves = {f.curve for f in data.fits}
    if curves:  # the fixture's stops are unresolved in the LWIR
        assert {"expected_eq4_rim", "expected_eq4_extent", "paper_small"} <= curves
        assert all(f.chi2_per_dof <= f.chi2_per_dof_measured for f in data.fits)
