"""Serial and telemetry device configuration: a TOML table -> a device instance, validated.

Example (``devices.toml``)::

    [gps]
    protocol = "nmea"          # nmea | gpsd | mavlink
    port = "/dev/ttyUSB0"      # pyserial URL; gpsd: "host:port"; mavlink: "udpin:0.0.0.0:14550"
    baud = 38400
    allow_no_checksum = ["POLYN"]
    stale_after_s = 1.0
    start_timeout_s = 10.0     # no reading within this long of the start: the command stops

    [lrf]
    protocol = "trupulse"      # trupulse | ldm
    port = "socket://192.168.1.20:4001"
    baud = 4800
    remote = true

Every key is checked: an unknown key, a wrong type or a bad value raises one
:class:`snrmon.drivers.errors.ConfigError` naming the table, the key and the value.
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from snrmon.config_schema import (
    Key,
    above,
    any_of,
    checked,
    int_at_least,
    is_bool,
    is_string,
    is_text,
    one_of,
    template,
)
from snrmon.drivers.device import Device
from snrmon.drivers.errors import ConfigError
from snrmon.drivers.serialport import SERIAL_BAUD_RATES

GPS_PROTOCOLS = ("nmea", "gpsd", "mavlink")
LRF_PROTOCOLS = ("trupulse", "ldm")
PROTOCOLS = GPS_PROTOCOLS + LRF_PROTOCOLS

_SECONDS = "a positive number of seconds (default: the device's own)"
_BAUD = Key(f"a standard rate {SERIAL_BAUD_RATES}", one_of(SERIAL_BAUD_RATES))
_COMMON: dict[str, Key] = {
    "protocol": Key(f"one of {', '.join(PROTOCOLS)}", one_of(PROTOCOLS), required=True),
    "port": Key(
        'a pyserial path or URL such as "/dev/ttyUSB0" (gpsd: "host:port"; mavlink: '
        '"udpin:0.0.0.0:14550")',
        is_string,
    ),
    "name": Key("a string, the device's name in logs and the recording", is_text),
    "stale_after_s": Key(_SECONDS, above(0)),
    "reopen_after_s": Key(_SECONDS, above(0)),
    "start_timeout_s": Key(_SECONDS, above(0)),
}
_EXTRA: dict[str, dict[str, Key]] = {
    "nmea": {
        "baud": _BAUD,
        "allow_no_checksum": Key(
            "true, false or a list of addresses",
            any_of(is_bool, lambda v: isinstance(v, list) and all(is_text(a) for a in v)),
        ),
        "max_line_bytes": Key("a positive integer (bytes)", int_at_least(1)),
    },
    "gpsd": {"device_path": Key("a string, the receiver's path in gpsd", is_text)},
    "mavlink": {"baud": _BAUD},
    "trupulse": {"baud": _BAUD, "remote": Key("true or false", is_bool)},
    "ldm": {
        "baud": _BAUD,
        "output_format": Key("a string, the LDM's output format", is_text),
        "averaging": Key("a positive integer (readings averaged)", int_at_least(1)),
        "track": Key("true or false", is_bool),
    },
}
EXAMPLES: dict[str, dict[str, Any]] = {
    "gps": {"protocol": "nmea", "port": "/dev/ttyUSB0", "baud": 38400},
    "lrf": {"protocol": "trupulse", "port": "/dev/ttyUSB1", "baud": 4800},
}
"""The template's device tables (:func:`device_template`)."""


@dataclass(frozen=True)
class DeviceSettings:
    """A ``[gps]`` or ``[lrf]`` table, checked (:func:`check_device_table`): one field per key
    of the schema (``_COMMON`` and each protocol's ``_EXTRA``; a test holds them to it), None
    where the table leaves the key out (the device's own default)."""

    protocol: str
    port: str | None = None
    name: str | None = None
    stale_after_s: float | None = None
    reopen_after_s: float | None = None
    start_timeout_s: float | None = None
    baud: int | None = None
    allow_no_checksum: bool | tuple[str, ...] | None = None  # nmea: true, or the addresses
    max_line_bytes: int | None = None
    device_path: str | None = None
    remote: bool | None = None
    output_format: str | None = None
    averaging: int | None = None
    track: bool | None = None

    @classmethod
    def from_table(cls, table: Any, name: str = "device") -> DeviceSettings:
        """The settings of a config table, every key checked (one ConfigError naming the table,
        the key, the value and what was expected)."""
        check_device_table(table, name)
        values = dict(table)
        if isinstance(values.get("allow_no_checksum"), list):
            values["allow_no_checksum"] = tuple(values["allow_no_checksum"])
        return cls(**values)

    def table(self) -> dict[str, Any]:
        """The settings as the TOML table they came from (the keys given, and only those)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if isinstance(self.allow_no_checksum, tuple):
            out["allow_no_checksum"] = list(self.allow_no_checksum)
        return {k: v for k, v in out.items() if v is not None}

    def device(self, name: str = "device") -> Device:
        """The device the settings describe (:func:`device_from_config`)."""
        return device_from_config(self.table(), name)


def schema_keys() -> set[str]:
    """Every key a device table may have, of any protocol."""
    return {k for protocol in PROTOCOLS for k in device_fields(protocol)}


def split_host_port(text: str, default_port: int, what: str) -> tuple[str, int]:
    """``host:port``, ``gpsd://host:port`` or ``host`` -> (host, port)."""
    text = text.removeprefix("gpsd://").removeprefix("tcp://")
    host, sep, port = text.rpartition(":")
    if not sep:
        return text or "127.0.0.1", default_port
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"{what}: port {port!r} in {text!r} is not 1..65535")
    return host or "127.0.0.1", int(port)


def device_fields(protocol: str) -> dict[str, Key]:
    """The keys of a protocol's table (snrmon.config_schema; the tests walk every one)."""
    return {**_COMMON, **_EXTRA[protocol]}


def check_device_table(table: Any, name: str = "device") -> str:
    """Check a device table's keys, types and values without building the device; returns the
    protocol. Every problem is one ConfigError naming the table, key, value and expectation."""
    where = f"[{name}]"
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: expected a table, got {type(table).__name__}")
    protocol = table.get("protocol")
    if protocol not in PROTOCOLS:
        raise ConfigError.expected(name, "protocol", protocol, _COMMON["protocol"].expected)
    checked(table, device_fields(protocol), name, error=ConfigError)
    if not table.get("port") and protocol != "gpsd":
        raise ConfigError(f"{where} port: missing (a path or URL such as /dev/ttyUSB0)")
    return protocol


def device_template() -> str:
    """The ``[gps]`` and ``[lrf]`` tables of a session template: the example's keys set, every
    other key of its protocol commented out, each with what it expects."""
    parts = []
    for table, example in EXAMPLES.items():
        keys = device_fields(example["protocol"])
        shown = {
            k: replace(spec, example=example[k]) if k in example else spec
            for k, spec in keys.items()
        }
        parts.append(template({table: shown}, active=()))
    return "\n".join(parts)


def device_from_config(table: dict[str, Any], name: str = "device") -> Device:
    """Build the device a table describes (see the module docstring)."""
    where = f"[{name}]"
    protocol = check_device_table(table, name)
    port = table.get("port")
    baud = table.get("baud")
    kw: dict[str, Any] = {"name": table.get("name", name)}
    for key in ("stale_after_s", "reopen_after_s"):
        if key in table:
            kw[key] = float(table[key])
    if baud is not None:
        kw["baudrate"] = baud
    try:
        return _build(protocol, port or "", table, kw, where)
    except ConfigError:
        raise
    except ValueError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def _build(protocol: str, port: str, table: dict, kw: dict, where: str) -> Device:
    # Imported here so that a config naming one protocol does not import the others.
    if protocol == "nmea":
        from snrmon.drivers.gps.nmea_device import NmeaGpsDevice

        allow = table.get("allow_no_checksum", False)
        if "max_line_bytes" in table:
            kw["max_line_bytes"] = table["max_line_bytes"]
        return NmeaGpsDevice(port, allow_no_checksum=allow, **kw)
    if protocol == "gpsd":
        from snrmon.drivers.gps.gpsd import GpsdDevice

        host, tcp_port = split_host_port(port, 2947, f"{where} port")
        return GpsdDevice(host, tcp_port, device_path=table.get("device_path"), **kw)
    if protocol == "mavlink":
        from snrmon.drivers.gps.mavlink import MavlinkGpsDevice

        return MavlinkGpsDevice(port, **kw)
    if protocol == "trupulse":
        from snrmon.drivers.rangefinder.trupulse import TruPulseDevice

        return TruPulseDevice(port, remote=table.get("remote", False), **kw)
    from snrmon.drivers.rangefinder.ldm import LdmDevice

    for key in ("output_format", "averaging", "track"):
        if key in table:
            kw[key] = table[key]
    return LdmDevice(port, **kw)


def devices_from_toml(path: str | Path) -> dict[str, Device]:
    """Every table of a TOML file as a device, keyed by table name."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    return {name: device_from_config(t, name) for name, t in data.items()}
