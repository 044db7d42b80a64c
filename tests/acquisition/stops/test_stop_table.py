"""The live stop table keeps the frames each final row summarised, and the headless demo's
report is built from them without a recording."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.prediction import ModelPredictor
from snrmon.acquisition.report.data import live_report_data
from snrmon.acquisition.report.plot import render_report
from snrmon.acquisition.runtime.session import row_payload
from snrmon.acquisition.stops.detector import StopDetector
from snrmon.acquisition.stops.table import StopTable

FRAME_NS = 16_666_667  # 60 fps


def _measure(rng, snr: float, flags=frozenset()) -> PeakSnr:
    bg_mean, bg_std = 4500.0 + rng.normal(0, 1), 5.0 + rng.normal(0, 0.2)
    return PeakSnr(640, 360, bg_mean + snr * bg_std, bg_mean, bg_std, snr, frozenset(flags))


@pytest.fixture(scope="module")
def table():
    """One marked stop at 336 m (GPS) with 5 lost frames, then 130 good ones; the stop ends."""
    rng = np.random.default_rng(2019)
    detector = StopDetector()
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    table = StopTable(detector, ["mwir"], predictor=predictor)
    t0 = 10**12
    detector.mark_stop(t0)
    for _ in range(20):
        detector.add_range(t0, 336.0, "gps")
    snrs = np.r_[np.full(5, 2.0), rng.normal(100.0, 18.0, 130)]
    for i, snr in enumerate(snrs):
        flags = {"lost"} if i < 5 else set()
        table.add("mwir", t0 + i * FRAME_NS, _measure(rng, float(snr), flags))
    detector.end_stop(t0 + len(snrs) * FRAME_NS)
    table.tick("mwir", t0 + len(snrs) * FRAME_NS)  # the camera passes the stop's end: final
    table.snrs = snrs
    table.t0 = t0
    return table


def test_final_row_keeps_the_100_frames_it_summarised(table):
    (row,) = table.rows()
    assert row.reading.complete and row.reading.n_frames == 100
    run = table.runs()[(0, "mwir")]
    times = [t for t, _ in run]
    assert times[0] == table.t0 + 5 * FRAME_NS  # the first valid frame after the lost ones
    assert np.diff(times).tolist() == [FRAME_NS] * 99
    values = np.array([m.snr for _, m in run])
    np.testing.assert_array_equal(values, table.snrs[5:105])
    assert row.reading.snr_mean == pytest.approx(values.mean(), rel=1e-12)
    assert row.reading.snr_std == pytest.approx(values.std(ddof=1), rel=1e-12)


def test_live_report_is_the_table_as_measured(table, tmp_path):
    data = live_report_data(table, {"mwir": "mwir"}, "uav1", name="demo (live)", seconds=2.3)
    (row,) = data.flight.rows
    (series,) = data.flight.series
    assert data.replay_seconds is None and data.path.name == "demo (live)"
    assert series.snr.mean() == pytest.approx(row.reading.snr_mean, rel=1e-12)
    np.testing.assert_allclose(series.t_s, (np.arange(5, 105) * FRAME_NS) / 1e9)
    np.testing.assert_allclose((series.peak - series.bg_mean) / series.bg_std, series.snr)
    (csv_row,) = data.csv_rows
    assert csv_row["ratio_small"] == pytest.approx(
        row.reading.snr_mean / row.model.model_snr["small"]
    )
    assert data.flight.points["mwir"].range_m.tolist() == [336.0]
    out = render_report(data, tmp_path / "live.pdf")
    assert out.stat().st_size > 10_000


def test_run_of_a_row_before_and_after_it_is_final():
    """``run_of`` gives the frames a row is summarised from: the run so far while the row is
    open (what the HIL rig reads its truth from), the frozen 100 once it is final."""
    rng = np.random.default_rng(7)
    detector = StopDetector()
    table = StopTable(detector, ["mwir"])
    t0 = 10**12
    detector.mark_stop(t0)
    for i in range(40):
        table.add("mwir", t0 + i * FRAME_NS, _measure(rng, 50.0))
    (row,) = table.rows()
    assert not row.reading.complete and row.reading.n_frames == 40
    open_run = table.run_of(0, "mwir")
    assert [t for t, _ in open_run] == [t0 + i * FRAME_NS for i in range(40)]
    for i in range(40, 150):
        table.add("mwir", t0 + i * FRAME_NS, _measure(rng, 50.0))
    (row,) = table.rows()
    assert row.reading.complete and not row.final
    assert len(table.run_of(0, "mwir")) == 100
    assert table.runs() == {}  # not final while the stop is open
    detector.end_stop(t0 + 150 * FRAME_NS)
    (final,) = table.tick("mwir", t0 + 150 * FRAME_NS)
    assert final.final and final.reading.snr_mean == row.reading.snr_mean
    assert table.run_of(0, "mwir") == table.runs()[(0, "mwir")]
    assert len(table.run_of(0, "mwir")) == 100
    assert table.run_of(1, "mwir") == [] and table.run_of(0, "lwir") == []


def test_a_row_counts_only_frames_before_an_end_known_late():
    """The end of a stop is known only after a few departing readings: frames that arrived
    before it was known but lie after it never enter the row, and a row is final only once
    the camera has passed the end, whatever the order the two threads ran in."""
    rng = np.random.default_rng(11)
    detector = StopDetector()
    finals = []
    table = StopTable(detector, ["mwir"], on_final=finals.append)
    t0 = 10**12
    detector.mark_stop(t0)
    for i in range(130):  # 60 valid, 1 lost, 69 valid: the end will fall at frame 90
        flags = {"lost"} if i == 60 else set()
        table.add("mwir", t0 + i * FRAME_NS, _measure(rng, 40.0 + i, flags))
    assert not table.rows()[0].reading.complete  # 69 consecutive after the loss: not 100
    detector.end_stop(t0 + 90 * FRAME_NS)
    assert finals == []  # the end is known, the camera has not been seen past it since
    (row,) = table.tick("mwir", t0 + 130 * FRAME_NS)
    assert finals == [row] and row.final and not row.reading.complete
    run = table.run_of(0, "mwir")
    assert [t for t, _ in run] == [t0 + i * FRAME_NS for i in range(60)]  # 60 > 29 before 90
    assert row.reading.snr_mean == pytest.approx(np.mean([40.0 + i for i in range(60)]), rel=1e-12)


def _one_stop(predictor, range_m: float, snr: float, *, seed: int):
    """A stop table with ``predictor`` and one 110-frame MWIR stop at ``range_m`` (GPS)."""
    rng = np.random.default_rng(seed)
    detector = StopDetector()
    table = StopTable(detector, ["mwir"], predictor=predictor)
    t0 = 10**12
    detector.mark_stop(t0)
    for _ in range(20):
        detector.add_range(t0, range_m, "gps")
    for i in range(110):
        table.add("mwir", t0 + i * FRAME_NS, _measure(rng, snr))
    (row,) = table.rows()
    return table, row


def test_the_reports_curves_are_drawn_at_the_sky_the_rows_were_compared_with():
    """A session whose model followed the measured sky (280 K against the model's own 288 K):
    each row keeps the background its model values were computed for, and the report draws
    the curves there, so a stop and the curve it is compared with agree (paper sections 8-9)."""
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    own = predictor.curves_background_k["mwir"]
    predictor.set_background("mwir", 280.0, wait=True)
    table, row = _one_stop(predictor, 336.0, 40.0, seed=5)
    assert own == pytest.approx(288.15) and row.model.model_sky_temp_k == pytest.approx(280.0)
    assert row.model.psf_source == "preset: PVF 0.082 (sensor mwir)"  # no PSF fitted yet
    assert row.model_psf_label == "preset PSF"
    data = live_report_data(table, {"mwir": "mwir"}, "uav1", name="demo (live)", seconds=2.0)
    curves = data.model.curves["mwir"]
    assert curves.background_temp_k == pytest.approx(280.0)
    at_stop = np.interp(np.log(336.0), np.log(curves.ranges_m), curves.snr["small"])
    assert at_stop == pytest.approx(row.model.model_snr["small"], rel=0.01)


def test_the_reports_corrected_curves_use_the_psf_the_rows_were_compared_with():
    """The console adopts the PSF measured from the flight for the corrected curves (the twin's
    MWIR: Airy x a 0.57 px blur, average PVF ~0.14, where the preset's PVF is 0.082): a row
    keeps the PSF its model values came from and the report draws the corrected curves with
    it. Before, the live report drew them with the preset's PSF, 40 % below the rows."""
    from snrmon.acquisition.calibrate.psf_estimate import _airy
    from snrmon.model.presets import load_sensor
    from snrmon.model.psf import AiryGaussianPsf

    sensor = load_sensor("mwir")
    measured = AiryGaussianPsf(_airy(sensor.f_number, sensor.pitch_um, tuple(sensor.band_um)), 0.57)
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    preset = predictor("mwir", 393.0)["small_corrected"]
    predictor.set_psf("mwir", measured, wait=True)
    table, row = _one_stop(predictor, 393.0, 60.0, seed=6)
    assert row.model.model_psf is measured
    # which PSF, in words, kept by the row but not recorded: the stop_summary payload (and so
    # the recording, the CSV and the campaign's Parquet) holds the fields it held before
    assert row.model.psf_source == "fitted: sigma 0.57 px from this flight's stops"
    assert row.model_psf_label == "fitted PSF"
    assert not any("source" in k or "label" in k for k in row_payload(row))
    assert row.model.model_snr["small_corrected"] > 1.4 * preset
    data = live_report_data(table, {"mwir": "mwir"}, "uav1", name="demo (live)", seconds=2.0)
    curves = data.model.curves["mwir"]
    for name in ("small_corrected", "expected_eq4_rim", "expected_eq4_extent"):
        at_stop = np.interp(np.log(393.0), np.log(curves.ranges_m), curves.snr[name])
        assert at_stop == pytest.approx(row.model.model_snr[name], rel=0.01), name
    assert "Airy x Gaussian blur 0.57 px" in curves.psf_label


def test_a_row_waits_for_its_stops_own_expected_reading_and_is_held_to_it():
    """``stop_model`` still computing (None): an open row with its 100 frames shows the cell's
    reading until the stop's is ready, then the stop's; past the stop's end the row stays open
    on a frame while it is computed, and is final on the next with it. Its measured / expected
    and band are of that reading; the cell's curve is still in the row beside it."""
    rng = np.random.default_rng(13)
    detector = StopDetector()
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    answers = [None, {"expected_eq4_rim_stop": 40.0}, None, {"expected_eq4_rim_stop": 40.0}]
    asked = []

    def stop_model(stop, camera, range_m, run, *, wait=False):
        asked.append((stop, camera, range_m, len(run), wait))
        return answers.pop(0)

    table = StopTable(detector, ["mwir"], predictor=predictor, stop_model=stop_model)
    t0 = 10**12
    detector.mark_stop(t0)
    for _ in range(20):
        detector.add_range(t0, 451.0, "gps")
    for i in range(110):
        table.add("mwir", t0 + i * FRAME_NS, _measure(rng, 44.0))
    (shown,) = table.rows()
    cell = shown.model.model_snr["expected_eq4_rim"]
    assert not shown.final and shown.expected_eq4 == cell != 40.0
    (shown,) = table.rows()
    assert not shown.final and shown.expected_eq4 == 40.0
    detector.end_stop(t0 + 110 * FRAME_NS)
    assert table.tick("mwir", t0 + 110 * FRAME_NS) == []  # being computed: not final yet
    (row,) = table.tick("mwir", t0 + 111 * FRAME_NS)
    assert asked == [(0, "mwir", 451.0, 100, False)] * 4
    assert row.final and row.expected_eq4_rule == "rim"
    assert row.model.model_snr["expected_eq4_rim"] == cell and row.expected_eq4 == 40.0
    assert row.agreement.expected == 40.0
    assert row.agreement.ratio == pytest.approx(row.reading.snr_mean / 40.0, rel=1e-12)
    assert row.agreement.lower == row.agreement.upper == 40.0  # no band given: the reading
