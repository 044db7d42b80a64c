"""``snrmon listen gps|lrf``: the field operator's "is it working?" tool for serial devices.

Prints each reading as it arrives (one JSON object per line with ``--json``), every line flushed;
status lines on stderr when the device cannot be opened (retried), goes stale, reconnects or
sends bad data.
"""

from __future__ import annotations

import argparse
import queue
import sys
import threading
import time
from typing import TYPE_CHECKING

from snrmon.drivers.config import GPS_PROTOCOLS, LRF_PROTOCOLS
from snrmon.inputs import Number, duration_s
from snrmon.output import dumps

if TYPE_CHECKING:  # the drivers are imported when the command runs: `--help` starts at once
    from snrmon.drivers.device import DeviceStatus
    from snrmon.drivers.gps.fix import GpsFix
    from snrmon.drivers.rangefinder.reading import RangeReading

DEFAULT_PROTOCOL = {"gps": "nmea", "lrf": "trupulse"}
DEFAULT_COUNT_TIMEOUT_S = 30.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("listen", help="print readings from a GPS or rangefinder as they arrive")
    p.add_argument("kind", choices=("gps", "lrf"), metavar="gps|lrf", help="what is on the port")
    p.add_argument(
        "--port",
        required=True,
        metavar="URL",
        help="path or pyserial URL (/dev/ttyUSB0, socket://h:p); gpsd: host:port; "
        "mavlink: udpin:0.0.0.0:14550",
    )
    p.add_argument(
        "--protocol",
        choices=GPS_PROTOCOLS + LRF_PROTOCOLS,
        metavar="|".join(GPS_PROTOCOLS + LRF_PROTOCOLS),
        help="default nmea for gps, trupulse for lrf",
    )
    p.add_argument("--baud", type=int, metavar="BAUD", help="line speed (default: the protocol's)")
    p.add_argument(
        "--count",
        type=Number(1, 10**9, integer=True),
        metavar="N",
        help="exit after N readings of any status",
    )
    p.add_argument(
        "--timeout",
        type=duration_s(),
        metavar="S",
        help=f"give up after S seconds (default {DEFAULT_COUNT_TIMEOUT_S:g} with "
        "--count, otherwise run until interrupted)",
    )
    p.add_argument(
        "--allow-no-checksum", action="store_true", help="NMEA: accept sentences without *hh"
    )
    p.add_argument("--json", action="store_true", help="one JSON object per line")
    p.set_defaults(func=run)


def gps_record(fix: GpsFix) -> dict:
    return {
        "t_host_ns": fix.t_host_ns,
        "utc": fix.utc.isoformat().replace("+00:00", "Z") if fix.utc else None,
        "lat": fix.lat_deg,
        "lon": fix.lon_deg,
        "alt_m": fix.alt_msl_m,
        "fix_quality": fix.fix_quality,
        "sats": fix.sats,
        "hdop": fix.hdop,
    }


def lrf_record(r: RangeReading) -> dict:
    return {
        "t_host_ns": r.t_host_ns,
        "range_m": r.range_m,
        "horizontal_m": r.horizontal_m,
        "azimuth_deg": r.azimuth_deg,
        "inclination_deg": r.inclination_deg,
        "quality": r.quality,
        "status": str(r.status),
    }


def _fmt(v: float | None, spec: str, unit: str = "") -> str:
    return "-" if v is None else f"{v:{spec}}{unit}"


def reading_line(reading: GpsFix | RangeReading) -> str:
    """The human-readable line for one reading."""
    from snrmon.drivers.gps.fix import GpsFix

    if isinstance(reading, GpsFix):
        rec = gps_record(reading)
        return (
            f"{rec['utc'] or 'no-date'} lat={_fmt(reading.lat_deg, '.7f')} "
            f"lon={_fmt(reading.lon_deg, '.7f')} alt={_fmt(reading.alt_msl_m, '.2f', ' m')} "
            f"q={reading.fix_quality} sats={_fmt(reading.sats, 'd')} "
            f"hdop={_fmt(reading.hdop, '.1f')}"
        )
    return (
        f"{reading.status} range={_fmt(reading.range_m, '.2f', ' m')} "
        f"horiz={_fmt(reading.horizontal_m, '.2f', ' m')} "
        f"az={_fmt(reading.azimuth_deg, '.1f')} inc={_fmt(reading.inclination_deg, '.1f')} "
        f"q={_fmt(reading.quality, 'd')}"
    )


class StatusReporter:
    """Turns status changes into stderr lines, once per event (not once per retry)."""

    def __init__(self, name: str) -> None:
        from snrmon.drivers.device import DeviceStatus

        self.name = name
        self._last = DeviceStatus(name=name)
        self._lock = threading.Lock()
        self.failed = threading.Event()

    def __call__(self, st: DeviceStatus) -> None:
        from snrmon.drivers.device import DeviceState

        with self._lock:
            old, self._last = self._last, st
        msgs = []
        if st.state is DeviceState.STALE and old.state is not DeviceState.STALE:
            msgs.append(f"stale: {st.last_error}, reopening")
        if st.state is DeviceState.FAILED:
            msgs.append(f"failed: {st.last_error}")
            self.failed.set()
        if st.reconnects > old.reconnects:
            msgs.append(f"reconnected (reconnects={st.reconnects})")
        if (
            st.state is not DeviceState.FAILED
            and st.last_error != old.last_error
            and st.last_error.startswith(("cannot open", "link"))
        ):
            msgs.append(f"{st.last_error}; retrying")
        bad = (st.parse_errors - old.parse_errors) + (st.checksum_errors - old.checksum_errors)
        if bad > 0:
            msgs.append(
                f"bad data ({st.parse_errors} parse, {st.checksum_errors} checksum errors): "
                f"{st.last_error}"
            )
        for m in msgs:
            print(f"snrmon listen: {self.name}: {m}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    from snrmon.drivers.config import device_from_config

    protocol = args.protocol or DEFAULT_PROTOCOL[args.kind]
    allowed = GPS_PROTOCOLS if args.kind == "gps" else LRF_PROTOCOLS
    if protocol not in allowed:
        raise ValueError(f"--protocol {protocol} is not a {args.kind} protocol ({allowed})")
    if args.count is not None and args.count <= 0:
        raise ValueError(f"--count must be positive, got {args.count}")
    timeout_s = args.timeout
    if timeout_s is None and args.count is not None:
        timeout_s = DEFAULT_COUNT_TIMEOUT_S
    if timeout_s is not None and timeout_s <= 0:
        raise ValueError(f"--timeout must be positive, got {timeout_s}")
    table: dict = {"protocol": protocol, "port": args.port, "name": args.kind}
    if args.baud is not None:
        table["baud"] = args.baud
    if args.allow_no_checksum:
        if protocol != "nmea":
            raise ValueError("--allow-no-checksum applies to --protocol nmea only")
        table["allow_no_checksum"] = True
    device = device_from_config(table, args.kind)
    readings: queue.Queue = queue.Queue()
    reporter = StatusReporter(args.kind)
    device.subscribe(readings.put)
    device.subscribe_status(reporter)
    record = gps_record if args.kind == "gps" else lrf_record
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    n = 0
    device.open()
    try:
        while args.count is None or n < args.count:
            if reporter.failed.is_set():
                raise OSError(f"{args.kind} on {args.port}: {device.status().last_error}")
            wait = 0.2 if deadline is None else min(0.2, deadline - time.monotonic())
            if wait <= 0:
                break
            try:
                reading = readings.get(timeout=wait)
            except queue.Empty:
                continue
            n += 1
            line = dumps(record(reading)) if args.json else reading_line(reading)
            print(line, flush=True)
    finally:
        device.close()
    if args.count is not None and n < args.count:
        print(
            f"snrmon listen: {args.kind}: timeout: {n} of {args.count} readings in "
            f"{timeout_s:g} s from {args.port}",
            file=sys.stderr,
            flush=True,
        )
        return 1
    return 0 if n else 1
