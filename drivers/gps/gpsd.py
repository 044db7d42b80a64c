"""gpsd client backend: TPV reports from a running gpsd (JSON protocol over TCP) as GpsFix.

Protocol (gpsd ``www/gpsd_json.adoc``): connect to port 2947, send
``?WATCH={"enable":true,"json":true}``, read one JSON object per line. ``TPV`` carries time,
``lat``, ``lon``, ``altMSL`` (``alt`` in older gpsd), ``altHAE``, ``mode`` (1 no fix, 2 2D, 3 3D)
and ``status`` (2 DGPS, 3 RTK fixed, 4 RTK float...); ``SKY`` carries ``uSat`` and ``hdop``.
"""

from __future__ import annotations

import json
import socket
import time
from datetime import datetime

from snrmon.drivers.device import Device
from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix

# gpsd TPV status -> GGA fix quality
_STATUS_TO_QUALITY = {2: 2, 3: 4, 4: 5, 5: 6, 6: 6, 8: 8}


def fix_from_tpv(tpv: dict, t_host_ns: int, sky: dict | None = None, raw: str = "") -> GpsFix:
    """A GpsFix from one TPV report (and the last SKY report for satellites and HDOP)."""
    mode = tpv.get("mode", 0)
    if not isinstance(mode, int):
        raise ParseError(f"gpsd: TPV mode {mode!r} is not an integer")
    quality = 0 if mode < 2 else _STATUS_TO_QUALITY.get(tpv.get("status", 1), 1)
    utc = None
    if isinstance(tpv.get("time"), str):
        try:
            utc = datetime.fromisoformat(tpv["time"].replace("Z", "+00:00"))
        except ValueError:
            raise ParseError(f"gpsd: TPV time {tpv['time']!r} is not ISO 8601") from None

    def num(key: str) -> float | None:
        v = tpv.get(key)
        if v is None:
            return None
        if not isinstance(v, int | float) or isinstance(v, bool):
            raise ParseError(f"gpsd: TPV {key} {v!r} is not a number")
        return float(v)

    sky = sky or {}
    sats = sky.get("uSat")
    hdop = sky.get("hdop")
    return GpsFix(
        t_host_ns=t_host_ns,
        utc=utc,
        lat_deg=num("lat"),
        lon_deg=num("lon"),
        alt_msl_m=num("altMSL") if "altMSL" in tpv else num("alt"),
        alt_ellipsoid_m=num("altHAE"),
        fix_quality=quality,
        sats=sats if isinstance(sats, int) else None,
        hdop=float(hdop) if isinstance(hdop, int | float) else None,
        raw=raw,
    )


class GpsdDevice(Device[GpsFix]):
    """GPS fixes from gpsd; one fix per TPV report.

    Args:
        host, port: where gpsd listens (default 127.0.0.1:2947).
        device_path: watch only this device (gpsd's ``"device"`` field); all devices if None.
        name: the device's name; **kwargs go to :class:`snrmon.drivers.device.Device`.
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 2947,
        *,
        device_path: str | None = None,
        name: str = "gps",
        **kwargs,
    ) -> None:
        # gpsd takes about 1.5 s from a client's WATCH to the first TPV (notes 2.3C).
        kwargs.setdefault("stale_after_s", 4.0)
        kwargs.setdefault("backoff_s", (0.2, 2.0))
        super().__init__(name, **kwargs)
        if not 0 < port < 65536:
            raise ValueError(f"{name}: gpsd port must be 1..65535, got {port}")
        self.host, self.port, self.device_path = host, port, device_path
        self._sock: socket.socket | None = None
        self._buf = b""
        self._sky: dict | None = None

    def _connect(self) -> None:
        sock = socket.create_connection((self.host, self.port), timeout=2.0)
        watch = {"enable": True, "json": True}
        if self.device_path:
            watch["device"] = self.device_path
        sock.sendall(b"?WATCH=" + json.dumps(watch, separators=(",", ":")).encode() + b";\n")
        sock.settimeout(0.1)
        self._sock, self._buf = sock, b""

    def _disconnect(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()

    def _read(self) -> list[GpsFix]:
        if self._sock is None:
            raise OSError(f"{self.name}: not connected to gpsd")
        try:
            data = self._sock.recv(65536)
        except TimeoutError:
            return []
        if not data:
            raise OSError(f"{self.name}: gpsd at {self.host}:{self.port} closed the connection")
        t_host_ns = time.monotonic_ns()
        self._buf += data
        *lines, self._buf = self._buf.split(b"\n")
        fixes = []
        for line in lines:
            if not line.strip():
                continue
            try:
                report = json.loads(line)
                if not isinstance(report, dict):
                    raise ParseError(f"gpsd: report is not an object: {line[:60]!r}")
                cls = report.get("class")
                if cls == "SKY":
                    self._sky = report
                elif cls == "TPV":
                    fixes.append(fix_from_tpv(report, t_host_ns, self._sky, line.decode()))
            except (ValueError, UnicodeDecodeError) as exc:  # JSONDecodeError is a ValueError
                self._count_error(
                    exc if isinstance(exc, ParseError) else ParseError(f"gpsd: {exc}")
                )
        return fixes
