"""The [gps] and [lrf] tables as the session uses them: typed settings, the devices they open."""

from __future__ import annotations

import pytest

from snrmon.acquisition.runtime.range_devices import (
    DEFAULT_START_TIMEOUT_S,
    RangeDevices,
    SerialDeviceSettings,
)
from snrmon.drivers.errors import ConfigError


def test_a_table_gives_its_start_timeout_and_its_device():
    gps = SerialDeviceSettings.of(
        {"protocol": "nmea", "port": "/dev/ttyUSB0", "start_timeout_s": 3}, "gps"
    )
    lrf = SerialDeviceSettings.of({"protocol": "trupulse", "port": "/dev/ttyUSB1"}, "lrf")
    assert gps is not None and lrf is not None
    assert (gps.start_timeout_s, lrf.start_timeout_s) == (3.0, DEFAULT_START_TIMEOUT_S)
    devices = RangeDevices(gps, lrf)  # built, not opened
    assert [d.name for d in devices.present()] == ["gps", "lrf"]
    assert devices.start_timeouts_s() == {"gps": 3.0, "lrf": DEFAULT_START_TIMEOUT_S}


def test_no_table_no_device_and_a_bad_one_is_refused_by_its_key():
    assert SerialDeviceSettings.of(None, "gps") is None
    assert list(RangeDevices(None, None).present()) == []
    bad = SerialDeviceSettings.of({"protocol": "nmea", "port": "/dev/x", "baud": 12345}, "gps")
    assert bad is not None
    with pytest.raises(ConfigError, match="baud"):
        bad.device()
