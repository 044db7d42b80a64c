"""Importing a flight log into a session: the real gpsd NMEA logs through the import
path, the clock mapping and the offset search on known data, the refusals."""

from __future__ import annotations

import json
from datetime import UTC, datetime, timedelta

import h5py
import numpy as np
import pytest

from snrmon.acquisition.record.gps_align import host_to_utc_ns, search_offset, utc_to_host_ns
from snrmon.acquisition.record.gps_import import gps_source, import_gps_log
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.acquisition.streams.timebase import ClockMap
from snrmon.cli import main
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.gps.nmea_log import read_nmea_log
from tests.drivers.gps.test_nmea_logs import golden_tpvs

T0_NS = 5 * 10**12


def bare_session(path, utc0: datetime, seconds: float) -> None:
    """A session whose clock maps T0_NS to ``utc0`` and which holds frames for ``seconds``
    and no GPS (the live feed was missing)."""
    clock = ClockMap()
    clock.update_from_gps(T0_NS, utc0)
    rec = SessionRecorder(
        path,
        config={"session": {"cameras": {"lwir": {"sensor": "lwir"}}}},
        cameras={"lwir": (8, 8)},
        clock=clock,
        fsync=False,
    )
    for i in range(int(seconds) + 1):
        rec.add_frame("lwir", Frame(np.full((8, 8), 1000, np.uint16), "lwir", i, T0_NS + i * 10**9))
    rec.stop()


@pytest.mark.parametrize("name", ["garmin15x", "nmea-rtk", "ublox-f9p-hpnmea"])
def test_real_nmea_log_imports_one_fix_per_epoch_at_its_utc(shared_data, tmp_path, name):
    log = shared_data / "nmea" / f"{name}.log"
    parsed = read_nmea_log(log)
    fixes = parsed.fixes
    utcs = [f.utc for f in fixes]
    assert utcs == sorted(set(utcs)) and len(fixes) >= 2  # one fix per epoch, in order
    # Every position gpsd reports for the log is one of our merged epochs.
    gold = {
        (round(t["lat"], 7), round(t["lon"], 7)) for t in golden_tpvs(log.with_suffix(".log.chk"))
    }
    ours = {(round(f.lat_deg, 7), round(f.lon_deg, 7)) for f in fixes if f.lat_deg is not None}
    assert gold <= ours
    span = (utcs[-1] - utcs[0]).total_seconds()
    session = tmp_path / "s.h5"
    bare_session(session, utcs[0], span)
    code = main(["gps-import", str(session), str(log), "--json"])
    assert code == 0
    with h5py.File(session, "r") as f:  # plain h5py reads it, no SWMR flags left
        gps = f["gps"][()]
        assert f["gps"].attrs["source"] == "imported"
        meta = json.loads(f["gps"].attrs["import_json"])
        assert "gps_live" not in f
    assert meta["kind"] == "nmea" and meta["fixes_written"] == len(fixes) == len(gps)
    assert meta["offset"]["applied"] is False and "no site" in meta["offset"]["reason"]
    # On the session clock exactly where the log's UTC says, positions and satellites kept.
    for row, fix in zip(gps, fixes, strict=True):
        assert int(row["t_host_ns"]) == T0_NS + round((fix.utc - utcs[0]).total_seconds() * 1e9)
        assert row["lat_deg"] == fix.lat_deg and row["lon_deg"] == fix.lon_deg
        assert int(row["sats"]) == (-1 if fix.sats is None else fix.sats)
    assert gps_source(session) == "imported"


def test_a_receivers_date_before_lock_is_left_out(shared_data, tmp_path):
    """mtk-3301 says 1980-01-05 (GPS week 0) until it has the almanac, then 2008-08-23: the
    log's clock is the 2008 epochs; the 1980 ones are outliers of the log, never written, and
    the import says how many."""
    log = shared_data / "nmea" / "mtk-3301.log"
    parsed = read_nmea_log(log)
    fixes = parsed.fixes
    assert {f.utc.year for f in fixes} == {2008} and parsed.clock.outliers == 8
    session = tmp_path / "s.h5"
    bare_session(session, fixes[0].utc, (fixes[-1].utc - fixes[0].utc).total_seconds())
    result = import_gps_log(session, log, "nmea")
    # The one 2008 epoch before the lock (quality 0) is a position without a fix: not written.
    assert result.placed.written == sum(f.has_fix for f in fixes) == len(fixes) - 1
    assert result.flight_log.dropped_no_fix == 1 and result.placed.outside == 0
    assert result.flight_log.clock["outliers"] == 8 and result.flight_log.clock["jumps"] == 3


def test_clock_mapping_round_trips_through_re_anchored_rows():
    rows = [
        (1_000, 10**18, b"host"),
        (5_000, 2 * 10**18, b"gps"),
        (9_000, 2 * 10**18 + 4_100, b"gps"),
    ]
    clock = np.array(rows, dtype=[("monotonic_ns", "<i8"), ("utc_ns", "<i8"), ("source", "S32")])
    t = np.array([5_000, 6_000, 8_999, 9_000, 12_000])
    utc = host_to_utc_ns(t, clock)
    assert list(utc - 2 * 10**18) == [0, 1_000, 3_999, 4_100, 7_100]
    assert list(utc_to_host_ns(utc, clock)) == list(t)
    # Before the GPS rows: extrapolated from the nearest one, never through the host's UTC.
    assert utc_to_host_ns(np.array([2 * 10**18 - 500]), clock)[0] == 4_500


def test_offset_search_finds_a_clock_error_and_refuses_a_hover():
    rng = np.random.default_rng(17)
    t_lrf = np.arange(0, 60e9, 1e8)  # 10 Hz for a minute
    r_true = lambda t: 50 + 4.0 * np.clip((t / 1e9 - 20) % 40, 0, 20)  # noqa: E731  out, back, out
    r_lrf = r_true(t_lrf) + rng.normal(0, 0.3, t_lrf.size)
    t_gps = np.arange(-5e9, 65e9, 1e8)
    shift = 2.37e9  # the log's times are 2.37 s late on the session clock
    found = search_offset(t_gps + shift, r_true(t_gps) + 1.5, t_lrf, r_lrf, min_offset_s=0.1)
    assert found.applied and found.offset_s == pytest.approx(-2.37, abs=0.02)
    assert found.rms_at_best_m < 0.5 < found.rms_at_zero_m  # the 1.5 m bias is not timing
    hover = search_offset(t_gps, np.full(t_gps.size, 80.0), t_lrf, np.full(t_lrf.size, 80.0))
    assert not hover.applied and "cannot time the log" in hover.reason


def test_import_refuses_a_live_stream_and_missing_files(tmp_path, capsys):
    from tests.acquisition.session_factory import write_session

    s = write_session(tmp_path / "s.h5", ranges_m=(120.0,), hover_s=2.0, transit_s=1.0)
    log = tmp_path / "log.nmea"
    log.write_bytes(b"$GPGGA,120000.00,3222.8,N,10628.8,W,1,08,0.9,1200.0,M,,M,,*7C\r\n")
    assert main(["gps-import", str(s.path), str(log)]) == 2
    err = capsys.readouterr().err
    assert "already holds a live GPS stream; give --replace" in err
    assert gps_source(s.path) == "live"
    assert main(["gps-import", str(tmp_path / "none.h5"), str(log)]) == 2
    assert "does not exist" in capsys.readouterr().err
    with pytest.raises(ValueError, match="no NMEA fix with a UTC date"):
        import_gps_log(s.path, log, "nmea", replace=True)  # GGA alone has no date


def test_dji_csv_sub_second_utc_and_satellites(tmp_path):
    """A simulated AirData export whose receiver's epochs sit 0.04 s after the tenths and whose
    flight starts 0.34 s into a second: its first fix is the receiver's first epoch of that
    second, on the ground (15:00:00.040, three rows before the flight), which AirData's time
    base puts on 15:00:00. Every fix reads 0.04 s before its epoch's UTC."""
    from snrmon.drivers.gps.dji_csv import read_dji_csv
    from snrmon.sim.flight import FlightPlan
    from snrmon.sim.flight_logs import flight_epochs, write_airdata_csv

    u0 = datetime(2019, 5, 14, 15, 0, 0, 340000, tzinfo=UTC)  # the log starts at .34 s
    times = [0.1 * k for k in range(25)]
    epochs = flight_epochs(FlightPlan(), times, [u0 + timedelta(seconds=t) for t in times])
    path = write_airdata_csv(tmp_path / "f.csv", epochs, sats=13)
    assert "15:00:00," in path.read_text()  # AirData's own column: whole seconds only
    fixes = read_dji_csv(path)
    assert len(fixes) == 3 + len(epochs)  # on the ground at .04, .14 and .24, then the flight
    assert fixes[0].utc == datetime(2019, 5, 14, 15, 0, 0, tzinfo=UTC)
    offsets = {
        round((f.utc - e.utc).total_seconds(), 6) for f, e in zip(fixes[3:], epochs, strict=True)
    }
    assert offsets == {-0.04}
    assert {f.sats for f in fixes} == {13}


def test_the_import_says_what_the_logs_clock_looked_like(shared_data, tmp_path, capsys):
    """The real AirData export into a session of its flight: the import prints its segments
    and outliers and records them with the import."""
    import gzip

    log = tmp_path / "air-2s.csv"
    log.write_bytes(gzip.decompress((shared_data / "dji-airdata" / "air-2s.csv.gz").read_bytes()))
    session = tmp_path / "s.h5"
    bare_session(session, datetime(2021, 9, 6, 2, 48, 9, tzinfo=UTC), 900.0)
    assert main(["gps-import", str(session), str(log)]) == 0
    out = capsys.readouterr().out
    assert (
        "the log's clock: 25 segments (24 gaps, 0 time jumps), 31 rows whose time disagrees "
        "(left out of the anchor's estimate, their fixes on the anchor's time); first: "
    ) in out
    with h5py.File(session, "r") as f:
        meta = json.loads(f["gps"].attrs["import_json"])
    assert meta["clock"]["anchors"] == 1 and meta["clock"]["outliers"] == 31
    assert meta["fixes_written"] > 0
