"""The [gps] and [lrf] tables as the session uses them: typed settings, the devices they open."""

from __future__ import annotations

import dataclasses

import pytest

from snrmon.acquisition.runtime.range_devices import (
    DEFAULT_START_TIMEOUT_S,
    RangeDevices,
    SerialDeviceSettings,
)
from snrmon.drivers.config import DeviceSettings, device_fields, schema_keys
from snrmon.drivers.errors import ConfigError


def _settings(table: dict, name: str) -> SerialDeviceSettings | None:
    return SerialDeviceSettings.of(DeviceSettings.from_table(table, name), name)


def test_a_table_gives_its_start_timeout_and_its_device():
    gps = _settings({"protocol": "nmea", "port": "/dev/ttyUSB0", "start_timeout_s": 3}, "gps")
    lrf = _settings({"protocol": "trupulse", "port": "/dev/ttyUSB1"}, "lrf")
    assert gps is not None and lrf is not None
    assert (gps.start_timeout_s, lrf.start_timeout_s) == (3.0, DEFAULT_START_TIMEOUT_S)
    devices = RangeDevices(gps, lrf)  # built, not opened
    assert [d.name for d in devices.present()] == ["gps", "lrf"]
    assert devices.start_timeouts_s() == {"gps": 3.0, "lrf": DEFAULT_START_TIMEOUT_S}


def test_no_table_no_device_and_a_bad_one_is_refused_by_its_key():
    assert SerialDeviceSettings.of(None, "gps") is None
    assert list(RangeDevices(None, None).present()) == []
    with pytest.raises(ConfigError, match=r"\[gps\] baud = 12345"):
        DeviceSettings.from_table({"protocol": "nmea", "port": "/dev/x", "baud": 12345}, "gps")


def test_the_typed_settings_have_a_field_per_schema_key_and_give_back_their_table():
    """The device schema (drivers.config's keys) and the typed settings agree, key for key: a
    key added to one and not the other fails here."""
    assert {f.name for f in dataclasses.fields(DeviceSettings)} == schema_keys()
    table = {"protocol": "nmea", "port": "/dev/ttyUSB0", "baud": 38400}
    table |= {"allow_no_checksum": ["POLYN"], "stale_after_s": 1.5}
    settings = DeviceSettings.from_table(table, "gps")
    assert settings.allow_no_checksum == ("POLYN",) and settings.baud == 38400
    assert settings.table() == table  # the keys given, and only those
    assert set(settings.table()) <= set(device_fields("nmea"))
