"""``snrmon demo``: the operator console on the simulated collection day (hardware in loop).

The simulated MWIR and LWIR cameras, rangefinder and GPS of ``snrmon hil`` speak their real
protocols over real interfaces; the console is the real one. A simulated operator clicks the
drone at the first stop and the console tracks it from there. On a machine with no display (or
with ``--headless``) the same session runs offscreen: the stop table is printed as it fills, and
a screenshot of the whole window and the report (paper Figs. 6-10 and 12) are saved at the end.
The report is built from the console's own stop table (``live_report_data``: the rows and the
frames each summarised, as measured), or, with ``--out``, from a replay of the recording.
"""

from __future__ import annotations

import argparse
import os
import threading
import time
from pathlib import Path

from snrmon.cli import UsageError
from snrmon.commands.gui import add_status_file_option, add_view_options, view_options
from snrmon.commands.hil import add_flight_options
from snrmon.commands.recording_options import add_compression_option
from snrmon.extras import require
from snrmon.inputs import duration_s, output_file
from snrmon.output import emit_json
from snrmon.progress import say


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the console on the simulated field test (no hardware)")
    p.add_argument("--headless", action="store_true", help="offscreen, print the stop table")
    p.add_argument(
        "--duration",
        type=duration_s(),
        metavar="S",
        help="close after S seconds (default: when the flight is over)",
    )
    p.add_argument(
        "--screenshot",
        type=Path,
        metavar="FILE.png",
        help="save the window at the end (headless default: out/demo.png)",
    )
    add_flight_options(p)
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="X",
        help="flight time per wall second (default: %(default)s)",
    )
    p.add_argument(
        "-o", "--out", type=Path, metavar="PATH", help="record the session into this file (.h5)"
    )
    add_compression_option(p)
    p.add_argument(
        "--report",
        type=Path,
        metavar="REPORT.pdf|png",
        help="render the report at the end: from the recording with --out, else from the "
        "live stop table (headless default: out/demo-report.pdf)",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print the result (stops, frames received and dropped) as one JSON object",
    )
    add_status_file_option(p)
    add_view_options(p)
    p.set_defaults(func=run)


def _has_display() -> bool:
    if os.environ.get("QT_QPA_PLATFORM", "") == "offscreen":
        return False
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _operate(rig, done: threading.Event, printed: set, verbose: bool) -> None:
    """The simulated operator: clicks the drone at the first stop (HilRig.step) and, headless,
    prints each stop-table row once it is final (not ``rig.result()``: its PSF fits and model
    runs each time would take the CPU the cameras need)."""
    from snrmon.rig.table import format_row

    try:
        while not done.is_set():
            if not rig.step():
                done.set()  # the flight is over: the console closes (run_console's until)
            if verbose:
                for row in rig.final_stops():
                    key = (row["camera"], row["planned_range_m"], row["lrf_range_m"])
                    if row["n_frames"] >= 100 and key not in printed:
                        printed.add(key)
                        print(format_row(row), flush=True)
            done.wait(0.5)  # the operator's pace
    finally:
        done.set()  # a failed step ends the day too, never leaves the window open forever


def _outputs(args: argparse.Namespace) -> tuple[dict, bool, Path | None, Path | None]:
    """(the view options, headless, screenshot, report): the files the demo will write and
    the console's look, checked before the flight (a bad one is exit 2 at once), the files'
    folders made."""
    if args.out is not None:
        output_file(args.out, "--out", suffixes=(".h5",), new=True)
    if not args.speed > 0:
        raise UsageError(f"--speed must be positive, got {args.speed}")
    if args.status_file is not None:
        output_file(args.status_file, "--status-file", suffixes=(".json",))
    view = view_options(args)
    headless = args.headless or not _has_display()
    screenshot = args.screenshot
    if screenshot is None and headless:
        screenshot = Path("out") / "demo.png"
    report = args.report
    if report is None and headless:
        report = Path("out") / "demo-report.pdf"
    if report is not None and report.suffix.lower() not in (".pdf", ".png"):
        raise UsageError(f"--report {report}: must end in .pdf or .png")  # before the flight
    for out in (screenshot, report):
        if out is not None:
            out.parent.mkdir(parents=True, exist_ok=True)
    return view, headless, screenshot, report


def _fly(rig, args, *, headless: bool, screenshot, view: dict, verbose: bool) -> None:
    """The day in the console: the simulated operator on its thread, the window until the
    flight is over (or ``--duration``), then the session stopped (:meth:`HilRig.finish`)."""
    from snrmon.gui.app import run_console

    done = threading.Event()
    printed: set = set()
    operator = threading.Thread(
        target=_operate, args=(rig, done, printed, verbose), name="operator", daemon=True
    )
    operator.start()
    try:
        run_console(
            rig.session,
            curves=rig.predictor.curve,
            headless=headless,
            duration_s=args.duration,  # the flight's end closes it (until=done)
            until=done,
            screenshot=screenshot,
            status_file=args.status_file,
            **view,
        )
    finally:
        done.set()
        operator.join(5.0)
    rig.finish()


def _live_report(rig, opts):
    """The report's data from the console's own stop table (no recording to replay)."""
    from snrmon.acquisition.report.data import live_report_data

    return live_report_data(
        rig.session.stop_table,
        {c: c for c in rig.cameras},
        opts.target,
        name=f"snrmon demo, seed {opts.seed} (live)",
        seconds=time.monotonic() - rig.t0,
        weather=opts.weather,
    )


def run(args: argparse.Namespace) -> int:
    require("gui", "the console demo")
    from snrmon.rig.rig import HilOptions, HilRig
    from snrmon.rig.table import TABLE_HEADER, format_result

    view, headless, screenshot, report = _outputs(args)
    opts = HilOptions(
        seed=args.seed,
        speed=args.speed,
        stops_m=args.stops,
        transit_mps=12.0,
        out=str(args.out) if args.out else None,
        compression=args.compression,
        adopt_psf=True,  # the model takes the PSF measured at each unresolved stop
    )
    rig = HilRig(opts)
    planned_s = rig.plan.duration_s / args.speed  # at the asked speed; a busy machine's is longer
    verbose = headless and not args.json  # --json: stdout holds the JSON object only
    if verbose:
        print(
            f"snrmon demo: simulated flight of {len(opts.stops_m)} stops, {planned_s:.0f} s, "
            "console offscreen; stops as they complete:",
            flush=True,
        )
        print(TABLE_HEADER, flush=True)
    with rig:
        _fly(rig, args, headless=headless, screenshot=screenshot, view=view, verbose=verbose)
        result = rig.result()
        live = _live_report(rig, opts) if report is not None and args.out is None else None
    if args.json:
        emit_json(result)
    else:
        print(format_result(result))
    if screenshot is not None:
        say(f"screenshot: {screenshot}")
    if report is not None:
        from snrmon.acquisition.report.data import report_data
        from snrmon.acquisition.report.plot import render_report

        data = live if live is not None else report_data(args.out, target=opts.target)
        render_report(data, report)
        say(f"report: {report}")
    # A device lost during the day ends the console as it ends hil: exit 1, one line naming it,
    # after the result (its devices_lost) and the report are out.
    rig.check_failures()
    return 0
