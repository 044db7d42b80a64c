"""``snrmon gps-import SESSION LOG``: a drone's own flight log (DJI AirData CSV or SRT, NMEA,
MAVLink tlog, ArduPilot DataFlash, PX4 ULog, u-blox UBX; its kind found from its content)
aligned to a session on UTC and recorded as its GPS stream, marked as imported
(:mod:`snrmon.acquisition.record.gps_import`; docs/session-format.md, docs/flight-logs.md)."""

from __future__ import annotations

import argparse
import math
import re
import sys

from snrmon.cli import UsageError
from snrmon.inputs import input_file, session_file

# The options before the log was a positional argument: each named its kind.
OLD_FLAGS = {"dji": "dji_csv", "srt": "dji_srt", "nmea": "nmea", "tlog": "tlog"}
# The optional parts of snrmon each reader needs (snrmon.extras).
NEEDS = {"tlog": "mavlink", "dataflash": "mavlink", "ulog": "flightlogs", "ubx": "flightlogs"}
_OFFSET = re.compile(r"^([+-])?(\d{1,2})(?::(\d{2}))?$")


def utc_offset_s(text: str) -> float:
    """``--utc-offset``: local time - UTC as ``+02:00``, ``-5``, ``+5:30`` or hours (``5.5``),
    in seconds, within -12..+14 h."""
    m = _OFFSET.match(text.strip())
    if m:
        hours = int(m[2]) + int(m[3] or 0) / 60
        value = -hours if m[1] == "-" else hours
    else:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
    if not (math.isfinite(value) and -12 <= value <= 14):
        raise argparse.ArgumentTypeError(
            f"must be local time - UTC as +HH:MM or hours within -12..+14, got {text!r}"
        )
    return value * 3600.0


def register(sub: argparse._SubParsersAction) -> None:
    from snrmon.drivers.gps.flight_log import FORMATS

    p = sub.add_parser(
        "gps-import",
        help="record a drone's own flight log (DJI CSV/SRT, NMEA, tlog, BIN, ULog, UBX) as a "
        "session's GPS stream",
    )
    p.add_argument("session", metavar="SESSION.h5", help="a finished snrmon session file")
    p.add_argument(
        "log",
        nargs="?",
        metavar="LOG",
        help="the flight log; its kind is found from its content (docs/flight-logs.md)",
    )
    p.add_argument(
        "--format",
        choices=FORMATS,
        help="read the log as this kind instead of detecting it",
    )
    for flag, kind in OLD_FLAGS.items():
        p.add_argument(f"--{flag}", metavar="LOG", help=f"deprecated: LOG --format {kind}")
    p.add_argument(
        "--utc-offset",
        type=utc_offset_s,
        metavar="+HH:MM",
        help="the drone's local time - UTC, for a log in local time (DJI SRT); default: the "
        "one time zone that puts the log within the session",
    )
    p.add_argument(
        "--replace",
        action="store_true",
        help="replace a live GPS stream (its rows are kept in /gps_live)",
    )
    p.add_argument(
        "--offset-s",
        type=float,
        metavar="S",
        help="add S seconds to the log's times instead of searching the offset",
    )
    p.add_argument(
        "--max-offset-s",
        type=float,
        default=10.0,
        metavar="S",
        help="search the offset against the rangefinder within +/- S seconds (default: "
        "%(default)s)",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def _log_and_kind(args: argparse.Namespace) -> tuple[str, str | None]:
    """The log's path and its kind where the command line forces one (a deprecated flag warns
    once, on one line)."""
    old = [(flag, getattr(args, flag)) for flag in OLD_FLAGS if getattr(args, flag)]
    given = ([args.log] if args.log else []) + [v for _, v in old]
    if len(given) != 1:
        raise UsageError(
            "give one flight log: snrmon gps-import SESSION.h5 LOG"
            + (f" (got {len(given)})" if given else "")
        )
    if not old:
        return args.log, args.format
    flag, log = old[0]
    kind = args.format or OLD_FLAGS[flag]
    print(
        f"{args.prog}: warning: --{flag} LOG is deprecated: give the log after the session "
        f"(its kind is detected; --format {OLD_FLAGS[flag]} forces it)",
        file=sys.stderr,
    )
    return log, kind


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.record.gps_import import gps_source, import_gps_log
    from snrmon.drivers.gps.flight_log import detect_format
    from snrmon.extras import require
    from snrmon.output import emit_json

    session_file(args.session)
    log, kind = _log_and_kind(args)
    input_file(log, "flight log")
    if kind is None:
        kind = detect_format(log)
    if kind in NEEDS:
        require(NEEDS[kind], f"a {kind} flight log")
    if args.offset_s is not None and not math.isfinite(args.offset_s):
        raise UsageError(f"--offset-s must be a number of seconds, got {args.offset_s}")
    if not (math.isfinite(args.max_offset_s) and 0 <= args.max_offset_s <= 3600):
        raise UsageError(f"--max-offset-s must be within 0..3600 s, got {args.max_offset_s}")
    if not args.replace and gps_source(args.session) == "live":
        raise UsageError(
            f"{args.session} already holds a live GPS stream; give --replace to import the log "
            "anyway (the live rows are kept in /gps_live)"
        )
    result = import_gps_log(
        args.session,
        log,
        kind,
        replace=args.replace,
        offset_s=args.offset_s,
        max_offset_s=args.max_offset_s,
        utc_offset_s=args.utc_offset,
    )
    if args.json:
        return emit_json(result.as_dict())
    placed, read = result.placed, result.flight_log
    o = placed.offset
    print(
        f"{result.session}: {placed.written} of {placed.in_log} fixes from "
        f"{read.path} ({kind}, UTC from {placed.utc_source}) written as /gps, source imported"
    )
    if read.clock is not None:
        c = read.clock
        fate = (
            "left out of the anchor's estimate, their fixes on the anchor's time"
            if c["anchors"]
            else "left out"
        )
        print(
            f"  the log's clock: {c['segments']} segments ({c['gaps']} gaps, {c['jumps']} time "
            f"jumps), {c['outliers']} rows whose time disagrees ({fate})"
            + (f"; first: {c['examples'][0]}" if c["examples"] else "")
        )
    if read.dropped_no_fix:
        print(f"  {read.dropped_no_fix} positions without a fix (before the lock) left out")
    for note in read.notes:
        print(f"  {note}")
    if placed.outside:
        print(f"  {placed.outside} fixes lie outside the session's span and were left out")
    if result.live_rows_kept:
        print(f"  the {result.live_rows_kept} live GPS rows are kept in /gps_live")
    rms = lambda v: "-" if v is None else f"{v:.2f} m"  # noqa: E731
    best = "-" if o.best_s is None else f"{o.best_s:+.3f} s"
    print(
        f"  offset {o.offset_s:+.3f} s ({'applied' if o.applied else 'not applied'}: {o.reason}); "
        f"search {o.searched_s[0]:+g}..{o.searched_s[1]:+g} s in {o.step_s:g} s steps over "
        f"{o.pairs} rangefinder readings: best {best}, RMS {rms(o.rms_at_best_m)} "
        f"(at 0: {rms(o.rms_at_zero_m)})"
    )
    return 0
