"""``snrmon listen`` against the pty simulators, as a subprocess (real flushing, real exit)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from snrmon.sim.devices.ldm_sim import LdmSimulator
from snrmon.sim.devices.nmea_sim import NmeaSimulator, fixed_position
from snrmon.sim.devices.trupulse_sim import TruPulseSimulator
from tests.helpers import strict_json

GPS_KEYS = {"t_host_ns", "utc", "lat", "lon", "alt_m", "fix_quality", "sats", "hdop"}
LRF_KEYS = {
    "t_host_ns",
    "range_m",
    "horizontal_m",
    "azimuth_deg",
    "inclination_deg",
    "quality",
    "status",
}


def listen(*args: str, timeout_s: float = 20.0) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "snrmon", "listen", *args],
        capture_output=True,
        text=True,
        timeout=timeout_s,
    )


def test_gps_json_lines() -> None:
    with NmeaSimulator(fixed_position(-33.5, 151.25, 12.0), rate_hz=20, baud=115200) as sim:
        r = listen("gps", "--port", sim.path, "--count", "4", "--json", "--baud", "115200")
    assert r.returncode == 0, r.stderr
    records = [strict_json(line) for line in r.stdout.splitlines()]
    assert len(records) == 4 and all(set(rec) == GPS_KEYS for rec in records)
    assert all(rec["lat"] == pytest.approx(-33.5) and rec["lon"] == 151.25 for rec in records)
    assert records[-1]["utc"].startswith("2019-05-14T15:00:") and records[-1]["alt_m"] == 12.0


def test_lrf_trupulse_json_with_no_target() -> None:
    with TruPulseSimulator(lambda t: 199.0, auto_fire_hz=10, baud=9600) as sim:
        sim.faults.no_target(1)
        r = listen("lrf", "--port", sim.path, "--count", "3", "--json", "--baud", "9600")
    assert r.returncode == 0, r.stderr
    records = [strict_json(line) for line in r.stdout.splitlines()]
    assert all(set(rec) == LRF_KEYS for rec in records)
    statuses = [rec["status"] for rec in records]
    assert set(statuses) <= {"ok", "no_target"} and "ok" in statuses
    assert all(rec["range_m"] == pytest.approx(199.0) for rec in records if rec["status"] == "ok")


def test_lrf_ldm_text_lines() -> None:
    with LdmSimulator(lambda t: 37.5, rate_hz=20) as sim:
        r = listen("lrf", "--protocol", "ldm", "--port", sim.path, "--count", "2")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 2 and all(line.startswith("ok range=37.50 m") for line in lines)


def test_bad_data_reported_on_stderr() -> None:
    with NmeaSimulator(rate_hz=20, baud=115200) as sim:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "snrmon",
                "listen",
                "gps",
                "--port",
                sim.path,
                "--count",
                "12",
                "--json",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            assert proc.stdout.readline()  # connected: the first reading was flushed
            sim.faults.corrupt_checksum(3)
            _out, err = proc.communicate(timeout=20)
        finally:
            proc.kill()
    assert proc.returncode == 0
    assert "checksum" in err and "bad data" in err


def test_missing_port_one_line_retried_and_times_out(tmp_path) -> None:
    missing = str(tmp_path / "ttyUSB9")
    r = listen("gps", "--port", missing, "--count", "1", "--timeout", "1.0")
    assert r.returncode == 1 and r.stdout == ""
    lines = r.stderr.splitlines()
    assert sum("cannot open" in line and missing in line for line in lines) == 1  # not per retry
    assert "timeout: 0 of 1 readings" in lines[-1]
    assert "Traceback" not in r.stderr


def test_wrong_protocol_for_kind_is_one_line() -> None:
    r = listen("lrf", "--protocol", "nmea", "--port", "/dev/null")
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "lrf" in r.stderr
