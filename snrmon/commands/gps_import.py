"""``snrmon gps-import``: a drone's own flight log (DJI AirData CSV, NMEA log, MAVLink tlog)
aligned to a session on UTC and recorded as its GPS stream, marked as imported
(:mod:`snrmon.acquisition.record.gps_import`; docs/session-format.md)."""

from __future__ import annotations

import argparse
import math

from snrmon.cli import UsageError
from snrmon.inputs import input_file, session_file


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "gps-import",
        help="record a drone's own flight log (DJI CSV, NMEA, tlog) as a session's GPS stream",
    )
    p.add_argument("session", metavar="SESSION.h5", help="a finished snrmon session file")
    log = p.add_mutually_exclusive_group()
    log.add_argument("--dji", metavar="FLIGHT.csv", help="a DJI flight record exported by AirData")
    log.add_argument("--nmea", metavar="LOG", help="a receiver's NMEA 0183 log")
    log.add_argument("--tlog", metavar="FILE.tlog", help="a MAVLink telemetry log")
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


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.record.gps_import import gps_source, import_gps_log
    from snrmon.output import emit_json

    session_file(args.session)
    logs = (("dji_csv", args.dji), ("nmea", args.nmea), ("tlog", args.tlog))
    given = [(k, v) for k, v in logs if v]
    if not given:
        raise UsageError("give the flight log: --dji FLIGHT.csv, --nmea LOG or --tlog FILE.tlog")
    kind, log = given[0]
    option = {"dji_csv": "--dji", "nmea": "--nmea", "tlog": "--tlog"}[kind]
    input_file(log, option)
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
    )
    if args.json:
        return emit_json(result.as_dict())
    o = result.offset
    print(
        f"{result.session}: {result.fixes_written} of {result.fixes_in_log} fixes from "
        f"{result.log} ({kind}, UTC from {result.utc_source}) written as /gps, source imported"
    )
    if result.clock is not None:
        c = result.clock
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
    if result.fixes_outside:
        print(f"  {result.fixes_outside} fixes lie outside the session's span and were left out")
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
