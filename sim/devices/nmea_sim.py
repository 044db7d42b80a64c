"""A simulated NMEA 0183 GPS receiver on a pty: 10 Hz GGA+RMC from a position provider, or a
replay of a real receiver's log.

The position provider is any callable ``position(t_s) -> (lat_deg, lon_deg, alt_m)`` (``t_s``:
seconds since start), so a simulated flight can drive the receiver. Sentences carry checksums
(written here again on purpose: the simulator speaks the protocol, it does not import drivers).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path

from snrmon.sim.devices.line_sim import LineSimulator, sentence
from snrmon.sim.devices.pty_port import check_baud_budget

Position = Callable[[float], tuple[float, float, float]]


def fixed_position(lat_deg: float, lon_deg: float, alt_m: float) -> Position:
    """A receiver that does not move."""
    return lambda t_s: (lat_deg, lon_deg, alt_m)


def _lat(v: float) -> tuple[str, str]:
    d = int(abs(v))
    return f"{d:02d}{(abs(v) - d) * 60:010.7f}", "N" if v >= 0 else "S"


def _lon(v: float) -> tuple[str, str]:
    d = int(abs(v))
    return f"{d:03d}{(abs(v) - d) * 60:010.7f}", "E" if v >= 0 else "W"


def gga_rmc(
    utc: datetime,
    lat_deg: float,
    lon_deg: float,
    alt_m: float,
    *,
    talker: str = "GP",
    quality: int = 1,
    sats: int = 12,
    hdop: float = 0.8,
    geoid_sep_m: float = 47.0,
    speed_kn: float = 0.0,
    course_deg: float = 0.0,
) -> tuple[bytes, bytes]:
    """One epoch's GGA and RMC sentences (with CR LF)."""
    hms = utc.strftime("%H%M%S") + f".{utc.microsecond // 10000:02d}"
    la, ns = _lat(lat_deg)
    lo, ew = _lon(lon_deg)
    gga = (
        f"{talker}GGA,{hms},{la},{ns},{lo},{ew},{quality},{sats:02d},{hdop:.1f},"
        f"{alt_m:.3f},M,{geoid_sep_m:.3f},M,,"
    )
    status = "A" if quality > 0 else "V"
    mode = "D" if quality == 2 else ("A" if quality > 0 else "N")
    rmc = (
        f"{talker}RMC,{hms},{status},{la},{ns},{lo},{ew},{speed_kn:.3f},{course_deg:.2f},"
        f"{utc.strftime('%d%m%y')},,,{mode}"
    )
    return sentence(gga), sentence(rmc)


def no_fix(utc: datetime, *, talker: str = "GP") -> tuple[bytes, bytes]:
    """One epoch of a receiver without a fix: empty position fields, quality 0, RMC void."""
    hms = utc.strftime("%H%M%S") + f".{utc.microsecond // 10000:02d}"
    gga = f"{talker}GGA,{hms},,,,,0,00,99.9,,M,,M,,"
    rmc = f"{talker}RMC,{hms},V,,,,,,,{utc.strftime('%d%m%y')},,,N"
    return sentence(gga), sentence(rmc)


class NmeaSimulator(LineSimulator):
    """GGA+RMC at ``rate_hz`` from ``position(t_s)``.

    Args:
        position: ``position(t_s) -> (lat_deg, lon_deg, alt_m)``, or None while the receiver
            has no fix; default a fixed point.
        rate_hz: epochs per second (10 for a drone GPS).
        baud: line speed; a :class:`BaudBudgetWarning` is issued when the rate does not fit
            (10 Hz GGA+RMC is about 1.5 kB/s: at least 19200 baud).
        start_utc: UTC of ``t_s = 0``.
        talker, quality, sats, hdop, geoid_sep_m: what the sentences report.
        link_path, seed: see :class:`LineSimulator`.
    """

    def __init__(
        self,
        position: Position | None = None,
        *,
        rate_hz: float = 10.0,
        baud: int = 38400,
        start_utc: datetime | None = None,
        talker: str = "GP",
        quality: int = 1,
        sats: int = 12,
        hdop: float = 0.8,
        geoid_sep_m: float = 47.0,
        link_path: str | Path | None = None,
        seed: int = 0,
    ) -> None:
        if rate_hz <= 0:
            raise ValueError(f"NMEA simulator rate_hz must be positive, got {rate_hz}")
        super().__init__(baud=baud, link_path=link_path, seed=seed)
        self.position = position or fixed_position(52.2163, 6.8850, 100.0)
        self.tick_period_s = 1.0 / rate_hz
        self.start_utc = start_utc or datetime(2019, 5, 14, 15, 0, 0, tzinfo=UTC)
        self.talker, self.quality, self.sats, self.hdop = talker, quality, sats, hdop
        self.geoid_sep_m = geoid_sep_m
        self.epochs = 0
        sample = gga_rmc(self.start_utc, -89.999999, -179.999999, 1000.0, talker=talker)
        self.link_load = check_baud_budget(
            rate_hz * sum(map(len, sample)), baud, f"NMEA simulator at {rate_hz:g} Hz"
        )

    def tick(self, t_s: float) -> list[bytes]:
        # The epoch time is the scheduled one, quantised like a receiver's (centiseconds): the
        # latest epoch due by now (never one still ahead: a simulated day's clock gives where
        # the drone is at an epoch only once the epoch is reached). A thread held up for more
        # than a period skips the epochs it missed, as a receiver does, rather than sending them
        # late under their old times (a position taken now, labelled with a time in the past,
        # would shift the session's GPS clock).
        k = max(self.epochs, math.floor(t_s / self.tick_period_s + 1e-6))
        self.epochs = k + 1
        t_epoch = k * self.tick_period_s
        utc = self.start_utc + timedelta(seconds=round(t_epoch, 2))
        pos = self.position(t_epoch)
        if pos is None:
            return list(no_fix(utc, talker=self.talker))
        lat, lon, alt = pos
        if not (math.isfinite(lat) and math.isfinite(lon) and math.isfinite(alt)):
            raise ValueError(f"position provider returned {lat}, {lon}, {alt} at t={t_epoch}")
        return list(
            gga_rmc(
                utc,
                lat,
                lon,
                alt,
                talker=self.talker,
                quality=self.quality,
                sats=self.sats,
                hdop=self.hdop,
                geoid_sep_m=self.geoid_sep_m,
            )
        )


def log_sentences(path: str | Path) -> list[bytes]:
    """The receiver output in a log: comment (``#``) and blank lines removed, CR LF endings."""
    lines = []
    for raw in Path(path).read_bytes().splitlines():
        if raw.strip() and not raw.startswith(b"#"):
            lines.append(raw.rstrip(b"\r\n") + b"\r\n")
    return lines


class NmeaReplaySimulator(LineSimulator):
    """Replays a real receiver log (e.g. ``tests/data/nmea/*.log``) line by line.

    Args:
        log: the log file.
        lines_per_s: replay speed.
        loop: start again at the end instead of going quiet.
    """

    def __init__(
        self,
        log: str | Path,
        *,
        lines_per_s: float = 100.0,
        baud: int = 115200,
        loop: bool = False,
        link_path: str | Path | None = None,
        seed: int = 0,
    ) -> None:
        super().__init__(baud=baud, link_path=link_path, seed=seed)
        self.lines = log_sentences(log)
        if not self.lines:
            raise ValueError(f"NMEA log {log} holds no sentences")
        self.loop = loop
        self.tick_period_s = 1.0 / lines_per_s
        self.index = 0
        check_baud_budget(
            lines_per_s * sum(map(len, self.lines)) / len(self.lines), baud, f"replay of {log}"
        )

    @property
    def finished(self) -> bool:
        return self.index >= len(self.lines) and not self.loop

    def tick(self, t_s: float) -> list[bytes]:
        if self.index >= len(self.lines):
            if not self.loop:
                return []
            self.index = 0
        line = self.lines[self.index]
        self.index += 1
        return [line]
