"""``snrmon campaign``: every session of a campaign through the replay engine, one task per
(session, camera) on Dask distributed, into one Parquet stop table, optional per-frame tables
and one report (:mod:`snrmon.campaign`; docs/campaign.md).

Exit status: 0 when every task succeeded, 1 when some failed (the outputs still hold the
others, and the JSON and ``campaign.json`` list each failure with its error), 2 for bad usage.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from snrmon.cli import UsageError
from snrmon.extras import require
from snrmon.inputs import input_file, output_file, output_folder, session_file
from snrmon.progress import frame_progress, say

STOP_TABLE = "stops.parquet"
FRAMES_DIR = "frames"
REPORT = "campaign-report.pdf"
SUMMARY = "campaign.json"


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "campaign",
        help="re-analyse many sessions on a Dask cluster: one stop table, one report",
    )
    p.add_argument("sessions", nargs="+", metavar="SESSION.h5", help="session files")
    p.add_argument(
        "-o", "--out", required=True, metavar="PATH", help="output folder (made if absent)"
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="an existing Dask scheduler (tcp://host:8786); its workers must see the files",
    )
    where.add_argument(
        "--workers",
        type=int,
        default=min(4, os.cpu_count() or 1),
        metavar="N",
        help="processes of the local cluster (default: %(default)s, the cores up to 4); 0 runs "
        "serially in this process without Dask",
    )
    p.add_argument("--settings", metavar="FILE.toml", help="re-analysis settings")
    p.add_argument("--frame-table", action="store_true", help="also a per-frame table per session")
    p.add_argument(
        "--report",
        metavar="REPORT.pdf|png",
        help=f"campaign report file (default DIR/{REPORT}); 'none' for no report",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    require("campaign", "a campaign")
    from snrmon.campaign.run import run_dask, run_serial
    from snrmon.campaign.settings import load_settings

    if args.workers is not None and args.workers < 0:
        raise UsageError(f"--workers must be 0 or more, got {args.workers}")
    if args.scheduler and "://" not in args.scheduler:
        raise UsageError(
            f"--scheduler must be an address like tcp://host:8786, got {args.scheduler!r}"
        )
    report = None if args.report == "none" else Path(args.report or Path(args.out) / REPORT)
    if report is not None and report.suffix.lower() not in (".pdf", ".png"):
        raise UsageError(f"--report {report}: the report must end in .pdf or .png")
    # Every input and output before a cluster starts or anything is written: one bad session
    # is one message, not an empty table and report after the workers came up.
    output_folder(args.out, "--out")
    if report is not None and report.parent != Path(args.out):
        output_file(report, "--report", suffixes=(".pdf", ".png"))
    elif report is not None and report.is_dir():
        raise IsADirectoryError(f"--report {report}: is a folder, not a file")
    if args.settings:
        input_file(args.settings, "--settings")
    for s in args.sessions:
        if args.scheduler and not Path(s).exists():
            continue  # a remote cluster's workers may see paths this machine does not
        session_file(s, "session file", with_frames=True)
    settings = load_settings(args.settings)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    # One bar on a terminal (snrmon.progress: none when piped, logged or with -q/--quiet).
    with frame_progress("campaign", unit="task") as bar:
        update = None if args.quiet else bar
        if args.scheduler or args.workers > 0:
            result = run_dask(
                args.sessions,
                settings,
                frames=args.frame_table,
                scheduler=args.scheduler,
                workers=args.workers,
                progress=update,
            )
        else:
            result = run_serial(args.sessions, settings, frames=args.frame_table, progress=update)
    return write_outputs(args, result, settings, out, report)


def write_outputs(args, result, settings, out: Path, report: Path | None) -> int:
    from snrmon import __version__
    from snrmon.campaign.report import write_campaign_report
    from snrmon.campaign.tables import write_frame_table, write_stop_table
    from snrmon.output import dumps, emit_json, strict

    rows = sorted(
        (r for t in result.tasks for r in t.stops),
        key=lambda r: (r["session"], r["camera"], r["stop"]),
    )
    frames = sum(t.n_frames for t in result.tasks)
    campaign = {
        "snrmon": __version__,
        "executor": result.executor,
        "seconds": result.seconds,
        "sessions": list(args.sessions),
        "labels": result.labels,
        "tasks": [
            {
                "session": t.session,
                "camera": t.camera,
                "frames": t.n_frames,
                "measured": t.n_measured,
                "stops": len(t.stops),
                "seconds": t.seconds,
                **t.info,
            }
            for t in sorted(result.tasks, key=lambda t: (t.session, t.camera))
        ],
        "failures": result.failures,
        "frames": frames,
        "frames_per_s": frames / result.seconds if result.seconds > 0 else None,
        "sessions_per_min": (
            60
            * (len(args.sessions) - len({f["session"] for f in result.failures}))
            / result.seconds
        )
        if result.seconds
        else None,
    }
    settings_d = strict(settings.as_dict())
    campaign = strict(campaign)
    table = write_stop_table(out / STOP_TABLE, rows, settings_d, campaign)
    frame_files = []
    if args.frame_table:
        (out / FRAMES_DIR).mkdir(exist_ok=True)
        by_session: dict[str, list] = {}
        for t in result.tasks:
            by_session.setdefault(t.session, []).append(t.frames)
        for name, cols in sorted(by_session.items()):
            path = out / FRAMES_DIR / (name.replace(os.sep, "__") + ".parquet")
            frame_files.append(str(write_frame_table(path, cols, settings_d, campaign)))
    if report is not None:
        write_campaign_report(report, rows, settings_d, campaign)
    summary = {
        **campaign,
        "settings": settings_d,
        "stop_table": str(table),
        "frame_tables": frame_files,
        "report": None if report is None else str(report),
    }
    (out / SUMMARY).write_text(dumps(summary, indent=1))
    if args.json:
        # The day as an ISO date (the Parquet column is a date).
        emit_json({**summary, "stops": [{**r, "day": r["day"].isoformat()} for r in rows]})
    else:
        print(
            f"{len(result.tasks)} tasks, {len(rows)} stop rows, {frames} frames in "
            f"{result.seconds:.1f} s on {result.executor} -> {table}"
        )
        for f in result.failures:
            cam = f" ({f['camera']})" if f["camera"] else ""
            say(f"FAILED {f['session']}{cam}: {f['error']}", "warning")
    return 1 if result.failures else 0
