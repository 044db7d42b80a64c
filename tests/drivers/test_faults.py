"""Faults injected through the pty simulators are survived and reported: unplug/replug
recovers and counts a reconnect; garbage, truncated and bad-checksum lines are counted, not
fatal; a silent device goes stale within the watchdog time."""

from __future__ import annotations

import threading
import time

import pytest

from snrmon.drivers.device import DeviceState, DeviceStatus
from snrmon.drivers.gps.nmea_device import NmeaGpsDevice
from snrmon.drivers.rangefinder.ldm import LdmDevice
from snrmon.drivers.rangefinder.reading import RangeStatus
from snrmon.sim.devices.ldm_sim import LdmSimulator
from snrmon.sim.devices.nmea_sim import NmeaSimulator


class Watch:
    """Waits on a device's status and readings with a Condition (no sleeps)."""

    def __init__(self, device) -> None:
        self.cond = threading.Condition()
        self.readings: list = []
        self.states: list[DeviceState] = []
        device.subscribe(self._reading)
        device.subscribe_status(self._status)
        self.device = device

    def _reading(self, r) -> None:
        with self.cond:
            self.readings.append(r)
            self.cond.notify_all()

    def _status(self, st: DeviceStatus) -> None:
        with self.cond:
            self.states.append(st.state)
            self.cond.notify_all()

    def until(self, predicate, timeout_s: float) -> bool:
        with self.cond:
            return self.cond.wait_for(predicate, timeout_s)


@pytest.fixture
def gps():
    sim = NmeaSimulator(rate_hz=20, baud=115200, seed=4).start()
    dev = NmeaGpsDevice(sim.path, baudrate=115200, stale_after_s=0.5, reopen_after_s=0.3)
    watch = Watch(dev)
    dev.open()
    assert watch.until(lambda: len(watch.readings) >= 2, 3.0)
    yield sim, dev, watch
    dev.close()
    sim.stop()


def test_unplug_replug_recovers_within_2_s_and_counts_a_reconnect(gps) -> None:
    sim, dev, watch = gps
    sim.unplug()
    assert watch.until(lambda: dev.status().state is not DeviceState.STREAMING, 2.0)
    assert dev.status().last_error != ""
    sim.replug()
    t0 = time.monotonic()
    n = len(watch.readings)
    assert watch.until(lambda: len(watch.readings) > n, 2.0)
    assert time.monotonic() - t0 < 2.0
    assert dev.status().reconnects == 1 and dev.status().state is DeviceState.STREAMING


def test_garbage_truncated_and_bad_checksum_counted_not_fatal(gps) -> None:
    sim, dev, watch = gps
    sim.faults.garbage(2)
    sim.faults.truncate(2)
    sim.faults.corrupt_checksum(3)
    assert watch.until(lambda: dev.status().checksum_errors >= 3, 3.0)
    assert watch.until(lambda: dev.status().parse_errors >= 2, 3.0)
    n = len(watch.readings)
    assert watch.until(lambda: len(watch.readings) >= n + 3, 2.0)  # still streaming
    st = dev.status()
    assert st.state is DeviceState.STREAMING and st.reconnects == 0
    assert sim.faults.applied["garbage"] == 2 and sim.faults.applied["truncate"] == 2


def test_silence_goes_stale_within_watchdog_then_recovers(gps) -> None:
    sim, dev, watch = gps
    sim.faults.silence()
    t0 = time.monotonic()
    assert watch.until(lambda: DeviceState.STALE in watch.states, 2.0)
    # stale_after_s = 0.5 plus one read timeout (0.1 s) and some scheduling slack
    assert time.monotonic() - t0 < 0.5 + 0.5
    assert watch.until(lambda: dev.status().reconnects >= 1, 2.0)  # the link was reopened
    sim.faults.silence(False)
    n = len(watch.readings)
    assert watch.until(lambda: len(watch.readings) > n, 2.0)
    assert dev.status().state is DeviceState.STREAMING


def test_over_long_line_counted_and_next_line_still_decoded(gps) -> None:
    sim, dev, watch = gps
    before = dev.status().parse_errors
    sim.send_raw(b"$GPTXT," + b"x" * 1000 + b"\r\n")
    assert watch.until(lambda: dev.status().parse_errors > before, 2.0)
    n = len(watch.readings)
    assert watch.until(lambda: len(watch.readings) > n, 2.0)


def test_no_target_replies_are_readings_with_status() -> None:
    with LdmSimulator(lambda t: 50.0, rate_hz=20) as sim:
        dev = LdmDevice(sim.path)
        watch = Watch(dev)
        dev.open()
        try:
            assert watch.until(lambda: len(watch.readings) >= 1, 3.0)
            sim.faults.no_target(2)
            assert watch.until(
                lambda: sum(r.status is RangeStatus.NO_TARGET for r in watch.readings) == 2, 3.0
            )
            assert watch.until(lambda: watch.readings[-1].status is RangeStatus.OK, 2.0)
        finally:
            dev.close()
