"""What the console's camera header reads, computed on the acquisition side: the error of the
mean of the running window, the model's expected Eq. (4) reading at the measured range with its
band and the measurement's ratio to it, and the open stop's progress.

A drone (a Gaussian spot, seeded noise) hovers at 336 m by the rangefinder; the session's own
engine measures it with the model's predictor. Each number is checked against an independent
rendering written here from its definition, not against the product's helpers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.engine.inputs import SetRoi
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.measure.model_agreement import model_agreement, verdict
from snrmon.acquisition.prediction import EXPECTED_EXTENT, EXPECTED_RIM, ModelPredictor
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.drivers.rangefinder.reading import RangeReading

H, W = 48, 64
X, Y = 30, 20
FRAME_NS = 16_666_667
T0 = 10**12


def _frame(i: int) -> np.ndarray:
    rng = np.random.default_rng([5, i])
    yy, xx = np.mgrid[0:H, 0:W]
    spot = 60.0 * np.exp(-((xx - X) ** 2 + (yy - Y) ** 2) / (2 * 0.8**2))
    return np.rint(1000.0 + spot + rng.normal(0.0, 5.0, (H, W))).astype(np.uint16)


def error_of_mean(x: np.ndarray) -> float:
    """std / sqrt(N_eff), N_eff = N / (1 + 2 sum_k (1 - k/N) rho_k) over the lags up to the
    first non-positive sample autocorrelation (Geyer's initial positive sequence)."""
    n = len(x)
    d = x - x.mean()
    c0 = np.dot(d, d) / n
    tau = 1.0
    for k in range(1, n - 1):
        rho = np.dot(d[:-k], d[k:]) / n / c0
        if rho <= 0:
            break
        tau += 2 * (1 - k / n) * rho
    return float(np.std(x, ddof=1) / math.sqrt(n / tau))


@pytest.fixture(scope="module")
def hover():
    config = session_config_from_dict({"cameras": {"mwir": {"source": "shm", "address": "x"}}})
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    engine = SessionEngine(config, {"mwir": (H, W)}, predictor=predictor)
    engine.camera("mwir").post(SetRoi(X, Y))
    engine.mark_stop(T0)
    for i in range(130):
        t = T0 + i * FRAME_NS
        if i % 6 == 0:  # the rangefinder at 10 Hz
            engine.on_range(RangeReading(t, 336.0, raw="336.0"))
        engine.on_frame(RingFrame(_frame(i), i, i, t, None, "mwir"))
    return engine, predictor


def test_the_header_s_snr_is_the_running_mean_with_its_error_of_the_mean(hover):
    engine, _ = hover
    st = engine.cameras["mwir"].status()
    m = st.last
    assert m is not None and m.snr_n == 100 and m.range_m == 336.0 and m.range_source == "lrf"
    window = engine.cameras["mwir"].series()[-100:, 1]  # the last 100 per-frame SNRs
    assert m.snr_mean == pytest.approx(window.mean(), rel=1e-9)
    assert st.snr_sem == pytest.approx(error_of_mean(window), rel=1e-9)
    assert 0 < st.snr_sem < m.snr_std


def test_the_expected_reading_its_band_and_the_ratio_are_the_model_s_at_the_range(hover):
    engine, predictor = hover
    st = engine.cameras["mwir"].status()
    a = st.agreement
    at = predictor("mwir", 336.0)
    # the rule the frame's background makes applicable: the paper's 7x7 rim for this spot
    EXPECTED = EXPECTED_RIM if st.last.result.background == "rim" else EXPECTED_EXTENT
    assert st.last.result.background == "rim"
    assert a is not None and a.rule == EXPECTED
    assert a.expected == at[EXPECTED]
    assert (a.lower, a.upper) == (at[f"{EXPECTED}_lower"], at[f"{EXPECTED}_upper"])
    assert a.lower < a.expected < a.upper
    assert a.ratio == pytest.approx(st.last.snr_mean / at[EXPECTED], rel=1e-12)
    assert a.ratio_lower == pytest.approx(a.lower / a.expected)
    inside = a.lower <= st.last.snr_mean <= a.upper
    gap = min(abs(st.last.snr_mean - a.lower), abs(st.last.snr_mean - a.upper))
    want = "inside" if inside else ("near" if gap <= 2 * st.snr_sem else "outside")
    assert a.verdict == want


def test_the_open_stop_s_progress_is_its_row_s_frame_count(hover):
    engine, _ = hover
    p = engine.cameras["mwir"].status().stop
    (row,) = engine.stops()
    assert p is not None and p.open and p.manual and p.stop == row.stop == 0
    assert p.n_frames == row.reading.n_frames == 100 and p.n_wanted == 100 and p.complete


def test_without_a_model_there_is_no_expected_reading():
    config = session_config_from_dict({"cameras": {"mwir": {"source": "shm", "address": "x"}}})
    engine = SessionEngine(config, {"mwir": (H, W)})
    engine.camera("mwir").post(SetRoi(X, Y))
    engine.on_range(RangeReading(T0, 336.0, raw="336.0"))
    engine.on_frame(RingFrame(_frame(0), 0, 0, T0, None, "mwir"))
    st = engine.cameras["mwir"].status()
    assert st.agreement is None and st.stop is None and math.isnan(st.snr_sem)


@pytest.mark.parametrize(
    ("measured", "sem", "want"),
    [
        (20.0, 1.0, "inside"),  # within [18, 22]
        (18.0, 0.0, "inside"),  # on the edge
        (23.5, 1.0, "near"),  # 1.5 above the band: within two errors of the mean
        (24.5, 1.0, "outside"),  # 2.5 above
        (15.0, 2.0, "near"),  # 3 below, errors of 2
        (15.0, float("nan"), "outside"),  # no error known, outside the band
        (float("nan"), 1.0, ""),  # nothing measured
    ],
)
def test_verdict_against_the_band(measured, sem, want):
    model = {"expected_eq4": 20.0, "expected_eq4_lower": 18.0, "expected_eq4_upper": 22.0}
    a = model_agreement(measured, sem, model, "expected_eq4")
    assert a is not None and a.verdict == want
    assert verdict(measured, sem, 18.0, 22.0) == want


def test_a_rule_the_model_does_not_state_is_no_agreement_and_no_band_is_a_point():
    assert model_agreement(10.0, 1.0, {"small": 12.0}, "expected_eq4") is None
    a = model_agreement(10.0, 1.0, {"expected_x": 11.0}, "expected_x")  # no band
    assert a is not None and a.lower == a.upper == 11.0 and a.verdict == "near"
    assert a.ratio == pytest.approx(10.0 / 11.0) and a.ratio_lower == a.ratio_upper == 1.0


def test_the_strip_chart_series_keeps_the_newest_rows_in_order_when_its_ring_wraps():
    """The per-frame rows for the strip chart: the newest ``series_length`` frames, oldest first,
    the same rows whether the ring has wrapped or not."""
    config = session_config_from_dict({"cameras": {"mwir": {"source": "shm", "address": "x"}}})
    rows = {}
    for length in (200, 48):  # 130 frames: kept whole, then wrapped twice and a bit
        engine = SessionEngine(config, {"mwir": (H, W)}, series_length=length)
        engine.camera("mwir").post(SetRoi(X, Y))
        for i in range(130):
            engine.on_frame(RingFrame(_frame(i), i, i, T0 + i * FRAME_NS, None, "mwir"))
        rows[length] = engine.cameras["mwir"].series()
    assert rows[200].shape == (130, 5)
    assert np.array_equal(rows[200][:, 0], T0 + np.arange(130.0) * FRAME_NS)
    np.testing.assert_array_equal(rows[48], rows[200][-48:])
