"""gpsd end to end: gpsd reads the NMEA simulator's pty; the gpsd backend reads gpsd's TPVs."""

from __future__ import annotations

import shutil
import socket
import subprocess
import threading

import pytest

from snrmon.drivers.gps.gpsd import GpsdDevice
from snrmon.sim.devices.nmea_sim import NmeaSimulator, fixed_position

pytestmark = pytest.mark.integration


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def gpsd_on_sim(tmp_path):
    gpsd = shutil.which("gpsd") or next(
        (p for p in ("/usr/sbin/gpsd", "/sbin/gpsd") if shutil.os.path.exists(p)), None
    )
    if gpsd is None:
        pytest.skip("gpsd is not installed (apt-get install gpsd)")
    sim = NmeaSimulator(fixed_position(41.5749659, -93.7505719, 278.161), rate_hz=10).start()
    port = free_port()
    proc = subprocess.Popen(
        [
            gpsd,
            "-N",
            "-n",
            "-S",
            str(port),
            "-F",
            str(tmp_path / "gpsd.sock"),
            "-P",
            str(tmp_path / "gpsd.pid"),
            sim.pts_path,
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        yield port
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
        sim.stop()


def test_fixes_through_gpsd(gpsd_on_sim) -> None:
    dev = GpsdDevice("127.0.0.1", gpsd_on_sim, backoff_s=(0.1, 0.5))
    fixes = []
    done = threading.Event()

    def on(fix) -> None:
        if fix.has_fix:
            fixes.append(fix)
            if len(fixes) >= 5:
                done.set()

    dev.subscribe(on)
    dev.open()
    try:
        assert done.wait(10.0), f"{len(fixes)} fixes from gpsd; status {dev.status()}"
    finally:
        dev.close()
    f = fixes[-1]
    assert f.lat_deg == pytest.approx(41.5749659, abs=1e-7)
    assert f.lon_deg == pytest.approx(-93.7505719, abs=1e-7)
    assert f.alt_msl_m == pytest.approx(278.161, abs=1e-3)
    assert f.alt_ellipsoid_m == pytest.approx(278.161 + 47.0, abs=1e-3)
    assert f.utc is not None and f.utc.year == 2019
