"""NMEA parser and assembler: checksum, talkers, GGA/RMC/GSA/VTG/ZDA, date combination."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from snrmon.drivers.errors import ChecksumError, ParseError
from snrmon.drivers.gps.nmea import NmeaAssembler, decode_gga, nmea_checksum, parse_sentence


def s(body: str) -> str:
    return f"${body}*{nmea_checksum(body):02X}"


GGA = "GPGGA,092750.000,5321.6802,N,00630.3372,W,1,8,1.03,61.7,M,55.2,M,,"
RMC = "GPRMC,092750.000,A,5321.6802,N,00630.3372,W,0.02,31.66,280511,,,A"


def test_checksum_of_known_sentence() -> None:
    # Garmin 15x line from the gpsd corpus, checksum as transmitted.
    line = "$GPRMC,113258,A,3238.9148,N,10822.4466,W,005.3,247.1,181022,009.3,E*6B"
    assert parse_sentence(line).kind == "RMC"


def test_wrong_checksum_is_checksum_error() -> None:
    with pytest.raises(ChecksumError):
        parse_sentence("$GPRMC,113258,A,3238.9148,N,10822.4466,W,005.3,247.1,181022,009.3,E*6C")


def test_gga_decodes_position_altitude_and_quality() -> None:
    g = decode_gga(parse_sentence(s(GGA)))
    assert g.lat_deg == pytest.approx(53 + 21.6802 / 60, abs=1e-9)
    assert g.lon_deg == pytest.approx(-(6 + 30.3372 / 60), abs=1e-9)
    assert (g.quality, g.sats, g.hdop, g.alt_msl_m, g.geoid_sep_m) == (1, 8, 1.03, 61.7, 55.2)


@pytest.mark.parametrize("talker", ["GP", "GN", "GL", "GA", "GB"])
def test_every_talker_gives_a_fix(talker: str) -> None:
    a = NmeaAssembler()
    fixes = a.feed(s(talker + GGA[2:]), 5)
    assert fixes[0].has_fix and fixes[0].t_host_ns == 5


def test_gga_time_takes_rmc_date_and_rmc_takes_gga_altitude() -> None:
    a = NmeaAssembler()
    first = a.feed(s(GGA), 1)[0]
    assert first.utc is None  # no date yet: GGA has none
    rmc = a.feed(s(RMC), 2)[0]
    assert rmc.utc == datetime(2011, 5, 28, 9, 27, 50, tzinfo=UTC)
    assert rmc.alt_msl_m == 61.7 and rmc.alt_ellipsoid_m == pytest.approx(116.9)
    nxt = a.feed(s(GGA.replace("092750.000", "092751.500")), 3)[0]
    assert nxt.utc == datetime(2011, 5, 28, 9, 27, 51, 500000, tzinfo=UTC)


def test_zda_date_and_midnight_rollover() -> None:
    a = NmeaAssembler()
    assert a.feed(s("GPZDA,235959.90,31,12,2019,00,00"), 0) == []
    fix = a.feed(s(GGA.replace("092750.000", "000000.10")), 0)[0]
    assert fix.utc == datetime(2020, 1, 1, 0, 0, 0, 100000, tzinfo=UTC)


def test_gsa_and_vtg_understood_not_errors() -> None:
    a = NmeaAssembler()
    assert a.feed(s("GPGSA,A,3,02,05,11,12,18,20,25,29,,,,,1.4,1.1,0.9"), 0) == []
    assert a.feed(s("GPVTG,0.00,T,,M,0.000,N,0.000,K,N"), 0) == []
    fix = a.feed(s(GGA.replace(",1.03,", ",,")), 0)[0]
    assert fix.hdop == 1.1  # from the GSA when GGA leaves it empty


def test_proprietary_counted_and_ignored() -> None:
    a = NmeaAssembler()
    assert a.feed("$PGRME,7.6,M,41.7,M,42.4,M*2F", 0) == []
    assert a.counts.proprietary == 1


def test_checksumless_only_where_configured() -> None:
    with pytest.raises(ParseError, match="no checksum"):
        NmeaAssembler().feed("$POLYN,TIME,RESTART_OCCURRED", 0)
    a = NmeaAssembler(allow_no_checksum={"POLYN"})
    assert a.feed("$POLYN,TIME,RESTART_OCCURRED", 0) == []
    with pytest.raises(ParseError):
        a.feed("$" + GGA, 0)  # GPGGA is not in the allowed set
    assert NmeaAssembler(allow_no_checksum=True).feed("$" + GGA, 0)[0].has_fix


def test_long_line_accepted() -> None:
    body = "GNGGA,132819.60,4134.49795459,N,09345.03431408,W,2,10,0.9,278.161,M,-31.442,M,6.6,0133"
    assert len(s(body)) + 2 > 82
    fix = NmeaAssembler().feed(s(body), 0)[0]
    assert fix.lat_deg == pytest.approx(41.574965910, abs=1e-9) and fix.fix_quality == 2


def test_rmc_void_is_not_a_fix() -> None:
    fix = NmeaAssembler().feed(s(RMC.replace(",A,5321", ",V,5321")), 0)[0]
    assert not fix.has_fix


@pytest.mark.parametrize(
    "bad",
    [
        GGA.replace("5321.6802", "53x1.6802"),
        GGA.replace(",N,", ",Q,"),
        GGA.replace("5321.6802", "9321.6802"),
        RMC.replace(",A,5321", ",X,5321"),
    ],
)
def test_bad_fields_are_parse_errors(bad: str) -> None:
    with pytest.raises(ParseError):
        NmeaAssembler().feed(s(bad), 0)


@pytest.mark.parametrize(
    "bad",
    [
        RMC.replace("280511", "2208-1"),  # a real receiver after the 2019 week rollover
        RMC.replace("280511", "310211"),  # 31 February
        RMC.replace("092750.000", "256000"),
        GGA.replace("092750.000", "256000"),
        GGA.replace("092750.000", "09:27:50"),
    ],
)
def test_checksummed_bad_date_or_time_keeps_the_position_time_unknown(bad: str) -> None:
    a = NmeaAssembler()
    a.feed(s(RMC), 0)  # a good date earlier must not be used to guess this fix's time
    fix = a.feed(s(bad), 7)[0]
    assert fix.utc is None and fix.t_host_ns == 7
    assert fix.lat_deg == pytest.approx(53 + 21.6802 / 60, abs=1e-9)
    assert fix.lon_deg == pytest.approx(-(6 + 30.3372 / 60), abs=1e-9)
    assert fix.has_fix and a.counts.bad_time == 1


def test_bad_rmc_date_never_becomes_the_date_of_later_fixes() -> None:
    a = NmeaAssembler()
    a.feed(s(RMC.replace("280511", "2208-1")), 0)
    assert a.feed(s(GGA), 0)[0].utc is None  # no date known yet: none is guessed
    a.feed(s(RMC), 0)
    assert a.feed(s(GGA), 0)[0].utc == datetime(2011, 5, 28, 9, 27, 50, tzinfo=UTC)


def test_bad_date_without_checksum_is_still_an_error() -> None:
    a = NmeaAssembler(allow_no_checksum=True)
    with pytest.raises(ParseError, match="2208-1"):
        a.feed("$" + RMC.replace("280511", "2208-1"), 0)
