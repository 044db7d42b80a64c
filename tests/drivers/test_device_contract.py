"""One contract, run against every serial driver with its pty simulator (the python-microscope
mixin pattern): readings arrive typed and timestamped, status counts them, close is clean."""

from __future__ import annotations

import threading
import time

import pytest

from snrmon.drivers.device import DeviceState
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.nmea_device import NmeaGpsDevice
from snrmon.drivers.rangefinder.ldm import LdmDevice
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus
from snrmon.drivers.rangefinder.trupulse import TruPulseDevice
from snrmon.sim.devices.ldm_sim import LdmSimulator
from snrmon.sim.devices.nmea_sim import NmeaSimulator, fixed_position
from snrmon.sim.devices.trupulse_sim import TruPulseSimulator


def collect(device, n: int, timeout_s: float = 3.0) -> list:
    got: list = []
    done = threading.Event()

    def on(reading) -> None:
        got.append(reading)
        if len(got) >= n:
            done.set()

    unsubscribe = device.subscribe(on)
    assert done.wait(timeout_s), f"{len(got)} of {n} readings in {timeout_s} s"
    unsubscribe()
    return got


class SerialDeviceContract:
    """Subclasses provide ``make()`` -> (simulator, device) and ``check(reading)``."""

    reading_type: type

    def make(self):
        raise NotImplementedError

    def check(self, reading) -> None:
        raise NotImplementedError

    @pytest.fixture
    def pair(self):
        sim, dev = self.make()
        sim.start()
        yield sim, dev
        dev.close()
        sim.stop()

    def test_readings_typed_timestamped_and_counted(self, pair) -> None:
        _sim, dev = pair
        dev.open()
        before = time.monotonic_ns()
        got = collect(dev, 3)
        after = time.monotonic_ns()
        assert all(isinstance(r, self.reading_type) for r in got)
        stamps = [r.t_host_ns for r in got]
        assert before <= stamps[0] and stamps == sorted(stamps) and stamps[-1] <= after
        for r in got:
            self.check(r)
        st = dev.status()
        assert st.state is DeviceState.STREAMING and st.readings >= 3
        assert st.parse_errors == 0 and st.checksum_errors == 0
        assert st.last_reading_age_s is not None and st.last_reading_age_s < 1.0

    def test_close_stops_readings_and_reports_disconnected(self, pair) -> None:
        _sim, dev = pair
        dev.open()
        collect(dev, 1)
        dev.close()
        n = dev.status().readings
        assert dev.status().state is DeviceState.DISCONNECTED
        more = threading.Event()
        dev.subscribe(lambda r: more.set())
        assert not more.wait(0.3) and dev.status().readings == n

    def test_iterator_yields_readings(self, pair) -> None:
        _sim, dev = pair
        dev.open()
        it = dev.iter_readings(timeout_s=3.0)
        assert isinstance(next(it), self.reading_type)
        it.close()

    def test_missing_port_is_retried_not_fatal(self, pair) -> None:
        sim, dev = pair
        sim.unplug()
        errors = threading.Event()
        dev.subscribe_status(lambda s: "cannot open" in s.last_error and errors.set())
        dev.open()
        assert errors.wait(2.0)
        assert dev.status().state is DeviceState.CONNECTING
        sim.replug()
        collect(dev, 1)


class TestNmeaContract(SerialDeviceContract):
    reading_type = GpsFix

    def make(self):
        sim = NmeaSimulator(fixed_position(48.1, 11.5, 520.0), rate_hz=20, baud=115200)
        return sim, NmeaGpsDevice(sim.path, baudrate=115200)

    def check(self, r: GpsFix) -> None:
        assert r.lat_deg == pytest.approx(48.1, abs=1e-7)
        assert r.lon_deg == pytest.approx(11.5, abs=1e-7)
        assert r.fix_quality == 1


class TestTruPulseContract(SerialDeviceContract):
    reading_type = RangeReading

    def make(self):
        sim = TruPulseSimulator(lambda t: 336.0, inclination_deg=2.0, auto_fire_hz=20, baud=38400)
        return sim, TruPulseDevice(sim.path, baudrate=38400)

    def check(self, r: RangeReading) -> None:
        assert r.status is RangeStatus.OK and r.range_m == pytest.approx(336.0)
        assert r.inclination_deg == pytest.approx(2.0)


class TestLdmContract(SerialDeviceContract):
    reading_type = RangeReading

    def make(self):
        sim = LdmSimulator(lambda t: 126.25, rate_hz=20)
        return sim, LdmDevice(sim.path)

    def check(self, r: RangeReading) -> None:
        assert r.status is RangeStatus.OK and r.range_m == pytest.approx(126.25)
        assert r.quality == 900  # the driver asked for format "s" on open


def test_trupulse_fires_on_demand_after_configuring_metres() -> None:
    with TruPulseSimulator(lambda t: 100.0, unit="F") as sim:
        dev = TruPulseDevice(sim.path, remote=True)
        dev.open()
        try:
            assert sim.wait_for_command("$DU,0", 2.0)  # sent on open: metres from now on
            dev.fire()
            (r,) = collect(dev, 1)
            assert r.range_m == pytest.approx(100.0) and "M" in r.raw
            assert dev.acks >= 3  # $MM,0, $DU,0 and $GO each acknowledged with $OK
        finally:
            dev.close()
