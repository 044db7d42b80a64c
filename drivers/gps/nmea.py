"""NMEA 0183 sentences to :class:`snrmon.drivers.gps.fix.GpsFix`: a pure parser and a stateful
assembler.

Our own parser rather than pynmeagps, because the contract here is narrower and stricter than a
general library's: every failure must be a :class:`snrmon.drivers.errors.ParseError` (the fuzz tests
hold us to it), checksum-less sentences are accepted only for the addresses a configuration names,
over-long lines are accepted, and proprietary sentences are counted and ignored.

Framing and checksums: :mod:`snrmon.drivers.gps.nmea_frame` (re-exported here). GGA carries time of
day, position, quality, satellites, HDOP and altitude but no date; RMC and ZDA carry the date,
so :class:`NmeaAssembler` combines them.

Leniency where it is safe (as gpsd does): a sentence whose checksum matches but whose date or
time field is malformed or impossible (a receiver after the 2019 GPS week rollover sends RMC
dates like ``2208-1``) keeps its position; its fix has ``utc = None`` (time unknown, never
guessed) and ``NmeaCounts.bad_time`` counts it. Without a checksum nothing vouches for the rest
of the sentence, so there a bad date or time is still a ParseError.
"""

from __future__ import annotations

import re
from collections.abc import Collection
from dataclasses import dataclass, field
from datetime import UTC, date, datetime, time, timedelta

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.nmea_frame import (  # noqa: F401 (re-exported: the module's public names)
    KNOWN_TYPES,
    POSITION_TYPES,
    TALKERS,
    Sentence,
    nmea_checksum,
    parse_sentence,
)

# Unicore receivers (UM98x) send high-precision twins of the standard sentences, the type
# followed by ``H`` (``$GNGGAH``, ``$GNRMCH``): the same fields in the same order, latitude and
# longitude to 8 decimals of a minute and heights to 0.1 mm (Unicore's NMEA reference). They
# decode as the standard sentence.
HIGH_PRECISION = {"GGAH": "GGA", "RMCH": "RMC", "GSAH": "GSA", "VTGH": "VTG", "ZDAH": "ZDA"}

_NUMBER = re.compile(r"^[+-]?(\d+(\.\d*)?|\.\d+)$")
_HMS = re.compile(r"^(\d{2})(\d{2})(\d{2})(\.\d+)?$")


# --------------------------------------------------------------------------- field decoders
def _field(s: Sentence, i: int) -> str:
    return s.fields[i] if i < len(s.fields) else ""


def _float(s: Sentence, i: int, what: str) -> float | None:
    v = _field(s, i)
    if v == "":
        return None
    if not _NUMBER.match(v):
        raise ParseError(f"NMEA {s.address}: {what} {v!r} is not a number")
    return float(v)


def _int(s: Sentence, i: int, what: str) -> int | None:
    v = _field(s, i)
    if v == "":
        return None
    if not v.isdigit() or len(v) > 6:
        raise ParseError(f"NMEA {s.address}: {what} {v!r} is not an integer")
    return int(v)


def _angle(s: Sentence, i: int, hemis: str, deg_digits: int, limit: float) -> float | None:
    """``ddmm.mmmm`` (latitude) or ``dddmm.mmmm`` (longitude) plus hemisphere -> degrees."""
    v, h = _field(s, i), _field(s, i + 1)
    if v == "":
        return None
    if not _NUMBER.match(v) or v[0] in "+-" or len(v.split(".")[0]) < deg_digits + 2:
        raise ParseError(f"NMEA {s.address}: coordinate {v!r} is not (d)ddmm.mmmm")
    head = v.split(".")[0]
    degrees = int(head[:-2])
    minutes = float(v[len(head) - 2 :])
    # 60.0 minutes occurs in receivers' no-fix placeholders (MTK: 8960.000000): accept it.
    if minutes > 60.0:
        raise ParseError(f"NMEA {s.address}: minutes {minutes} > 60 in {v!r}")
    value = degrees + minutes / 60.0
    if value > limit:
        raise ParseError(f"NMEA {s.address}: coordinate {value} deg beyond {limit}")
    if h not in hemis:
        raise ParseError(f"NMEA {s.address}: hemisphere {h!r} not one of {hemis}")
    return -value if h == hemis[1] else value


def _hms(s: Sentence, i: int) -> time | None:
    v = _field(s, i)
    if v == "":
        return None
    m = _HMS.match(v)
    if not m:
        raise ParseError(f"NMEA {s.address}: time {v!r} is not hhmmss.ss")
    hh, mm, ss = int(m[1]), int(m[2]), int(m[3])
    frac = float(m[4]) if m[4] and len(m[4]) > 1 else 0.0
    if hh > 23 or mm > 59 or ss > 60:
        raise ParseError(f"NMEA {s.address}: time {v!r} out of range")
    return time(hh, mm, min(ss, 59), min(round(frac * 1e6), 999_999))


@dataclass(frozen=True, slots=True)
class Gga:
    tod: time | None
    lat_deg: float | None
    lon_deg: float | None
    quality: int
    sats: int | None
    hdop: float | None
    alt_msl_m: float | None
    geoid_sep_m: float | None
    time_error: str = ""  # why a checksummed sentence's time was set aside (lenient decode)


@dataclass(frozen=True, slots=True)
class Rmc:
    tod: time | None
    valid: bool
    lat_deg: float | None
    lon_deg: float | None
    speed_kn: float | None
    course_deg: float | None
    day: date | None
    time_error: str = ""  # why a checksummed sentence's date or time was set aside


@dataclass(frozen=True, slots=True)
class Gsa:
    fix_mode: int | None  # 1 none, 2 2D, 3 3D
    pdop: float | None
    hdop: float | None
    vdop: float | None


@dataclass(frozen=True, slots=True)
class Vtg:
    course_deg: float | None
    speed_kmh: float | None


@dataclass(frozen=True, slots=True)
class Zda:
    tod: time | None
    day: date | None


def _alt(s: Sentence, i: int, what: str) -> float | None:
    v = _float(s, i, what)
    unit = _field(s, i + 1)
    if v is not None and unit not in ("M", ""):
        raise ParseError(f"NMEA {s.address}: {what} unit {unit!r} is not M")
    return v


def _lenient(s: Sentence, decode, *args):
    """``decode(s, *args)``, or (None, the error) when the sentence is checksummed (see the
    module docstring); a sentence without a checksum stays strict."""
    try:
        return decode(s, *args), ""
    except ParseError as exc:
        if not s.has_checksum:
            raise
        return None, str(exc)


def decode_gga(s: Sentence) -> Gga:
    quality = _int(s, 5, "quality")
    tod, time_error = _lenient(s, _hms, 0)
    return Gga(
        tod=tod,
        lat_deg=_angle(s, 1, "NS", 2, 90.0),
        lon_deg=_angle(s, 3, "EW", 3, 180.0),
        quality=quality or 0,
        sats=_int(s, 6, "satellites"),
        hdop=_float(s, 7, "HDOP"),
        alt_msl_m=_alt(s, 8, "altitude"),
        geoid_sep_m=_alt(s, 10, "geoid separation"),
        time_error=time_error,
    )


def _ddmmyy(s: Sentence, i: int) -> date | None:
    v = _field(s, i)
    if v == "":
        return None
    if len(v) != 6 or not v.isdigit():
        raise ParseError(f"NMEA {s.address}: date {v!r} is not ddmmyy")
    # NMEA's two-digit year: gpsd pivots at 1980 (GPS epoch); 80..99 -> 19xx.
    yy = int(v[4:])
    try:
        return date(1900 + yy if yy >= 80 else 2000 + yy, int(v[2:4]), int(v[:2]))
    except ValueError:
        raise ParseError(f"NMEA {s.address}: date {v!r} does not exist") from None


def decode_rmc(s: Sentence) -> Rmc:
    status = _field(s, 1)
    if status not in ("A", "V", ""):
        raise ParseError(f"NMEA {s.address}: status {status!r} is not A or V")
    tod, tod_error = _lenient(s, _hms, 0)
    day, day_error = _lenient(s, _ddmmyy, 8)
    return Rmc(
        tod=tod,
        valid=status == "A",
        lat_deg=_angle(s, 2, "NS", 2, 90.0),
        lon_deg=_angle(s, 4, "EW", 3, 180.0),
        speed_kn=_float(s, 6, "speed"),
        course_deg=_float(s, 7, "course"),
        day=day,
        time_error="; ".join(e for e in (tod_error, day_error) if e),
    )


def decode_gsa(s: Sentence) -> Gsa:
    return Gsa(
        _int(s, 1, "fix mode"), _float(s, 14, "PDOP"), _float(s, 15, "HDOP"), _float(s, 16, "VDOP")
    )


def decode_vtg(s: Sentence) -> Vtg:
    return Vtg(_float(s, 0, "course"), _float(s, 6, "speed"))


def decode_zda(s: Sentence) -> Zda:
    dd, mm, yyyy = (_int(s, i, "date") for i in (1, 2, 3))
    day = None
    if dd is not None and mm is not None and yyyy is not None:
        try:
            day = date(yyyy, mm, dd)
        except ValueError:
            raise ParseError(f"NMEA {s.address}: date {yyyy}-{mm}-{dd} does not exist") from None
    return Zda(_hms(s, 0), day)


# --------------------------------------------------------------------------- assembler
@dataclass
class NmeaCounts:
    """What the assembler saw besides fixes (proprietary and other sentences are not errors)."""

    sentences: int = 0
    proprietary: int = 0
    ignored: int = 0
    no_checksum: int = 0
    bad_time: int = 0  # positions kept with the time unknown (malformed date/time, checksum ok)
    by_address: dict[str, int] = field(default_factory=dict)


class NmeaAssembler:
    """Turns a stream of lines into fixes: one :class:`GpsFix` per GGA or RMC decoded.

    The UTC time is the sentence's time of day on the last date RMC or ZDA gave (rolled over to
    the next day when the time of day wraps past midnight); ``None`` until a date is known.
    An RMC fix takes altitude, quality, satellites and HDOP from the GGA of the same epoch.

    Args:
        allow_no_checksum: see :func:`parse_sentence`.
    """

    def __init__(self, *, allow_no_checksum: bool | Collection[str] = False) -> None:
        self.allow_no_checksum = allow_no_checksum
        self.counts = NmeaCounts()
        self._day: date | None = None
        self._day_tod: time | None = None
        self._gga: Gga | None = None
        self._hdop_gsa: float | None = None

    def feed(self, line: bytes | str, t_host_ns: int) -> list[GpsFix]:
        """Decode one line; returns the fixes it completes (zero or one). Raises ParseError."""
        s = parse_sentence(line, allow_no_checksum=self.allow_no_checksum)
        c = self.counts
        c.sentences += 1
        c.by_address[s.address] = c.by_address.get(s.address, 0) + 1
        if not s.has_checksum:
            c.no_checksum += 1
        if s.proprietary:
            c.proprietary += 1
            return []
        if s.talker not in TALKERS:
            c.ignored += 1
            return []
        kind = HIGH_PRECISION.get(s.kind, s.kind)
        if kind == "GGA":
            return [self._from_gga(decode_gga(s), s.raw, t_host_ns)]
        if kind == "RMC":
            return [self._from_rmc(decode_rmc(s), s.raw, t_host_ns)]
        if kind == "ZDA":
            z = decode_zda(s)
            if z.day is not None:
                self._set_day(z.day, z.tod)
        elif kind == "GSA":
            self._hdop_gsa = decode_gsa(s).hdop
        elif kind == "VTG":
            decode_vtg(s)  # validated; course and speed are not part of a GpsFix
        else:
            c.ignored += 1
        return []

    def _set_day(self, day: date, tod: time | None) -> None:
        self._day, self._day_tod = day, tod

    def _utc(self, tod: time | None) -> datetime | None:
        if tod is None or self._day is None:
            return None
        day = self._day
        if self._day_tod is not None:
            # A GGA just after midnight with the date from an RMC just before it.
            secs = lambda t: t.hour * 3600 + t.minute * 60 + t.second  # noqa: E731
            if secs(tod) - secs(self._day_tod) < -43200:
                day = day + timedelta(days=1)
        return datetime.combine(day, tod, tzinfo=UTC)

    def _from_gga(self, g: Gga, raw: str, t_host_ns: int) -> GpsFix:
        self._gga = g
        if g.time_error:
            self.counts.bad_time += 1
        return GpsFix(
            t_host_ns=t_host_ns,
            utc=self._utc(g.tod),
            lat_deg=g.lat_deg,
            lon_deg=g.lon_deg,
            alt_msl_m=g.alt_msl_m,
            alt_ellipsoid_m=(
                g.alt_msl_m + g.geoid_sep_m
                if g.alt_msl_m is not None and g.geoid_sep_m is not None
                else None
            ),
            fix_quality=g.quality,
            sats=g.sats,
            hdop=g.hdop if g.hdop is not None else self._hdop_gsa,
            raw=raw,
        )

    def _from_rmc(self, r: Rmc, raw: str, t_host_ns: int) -> GpsFix:
        if r.time_error:
            self.counts.bad_time += 1
        elif r.day is not None:
            self._set_day(r.day, r.tod)
        same_epoch = self._gga is not None and r.tod is not None and self._gga.tod == r.tod
        g = self._gga if same_epoch else None
        quality = (g.quality if g is not None and g.quality > 0 else 1) if r.valid else 0
        return GpsFix(
            t_host_ns=t_host_ns,
            utc=None if r.time_error else self._utc(r.tod),
            lat_deg=r.lat_deg,
            lon_deg=r.lon_deg,
            alt_msl_m=g.alt_msl_m if g else None,
            alt_ellipsoid_m=(
                g.alt_msl_m + g.geoid_sep_m
                if g and g.alt_msl_m is not None and g.geoid_sep_m is not None
                else None
            ),
            fix_quality=quality,
            sats=g.sats if g else None,
            hdop=(g.hdop if g else None) or self._hdop_gsa,
            raw=raw,
        )
