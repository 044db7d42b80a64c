"""``snrmon report``: the SNR-versus-range report of a session file (PDF or PNG) and its CSV.

The session is replayed through the live measurement (a tqdm bar on a terminal shows the frames),
stops are rebuilt, and the pages of :mod:`snrmon.acquisition.report.plot` are written; ``--csv``
writes the stop table with :data:`snrmon.acquisition.report.stop_csv.CSV_COLUMNS`. See
docs/report.md. With ``--json`` the result is one object on stdout: ``{"report", "stop_rows",
"csv" (or null)}``.
"""

from __future__ import annotations

import argparse

from snrmon.inputs import output_file, session_file
from snrmon.output import emit_json
from snrmon.progress import frame_progress, say


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report",
        help="SNR-versus-range report of a session (Figs. 6, 7-10, 12) as PDF or PNG, and a CSV",
    )
    p.add_argument("session", metavar="SESSION.h5", help="a snrmon session file")
    p.add_argument("-o", "--out", required=True, metavar="PATH", help="report file (.pdf or .png)")
    p.add_argument("--csv", metavar="TABLE.csv", help="also write the stop table as CSV")
    p.add_argument(
        "--target",
        metavar="uav1|uav2|FILE",
        help="target preset or TOML (default: the session's)",
    )
    p.add_argument(
        "--noise",
        choices=("model", "measured"),
        default="model",
        metavar="model|measured",
        help="the model's noise: its own (Eq. 1) or each camera's 3D noise measured on the "
        "stops' backgrounds, sqrt(sigma_tvh^2 + sigma_vh^2) (replays the session twice) "
        "(default: %(default)s)",
    )
    p.add_argument(
        "--no-paper-curves",
        action="store_true",
        help="leave out the paper's switched resolved/unresolved curves",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.report.data import report_data
    from snrmon.acquisition.report.plot import FORMATS, render_report
    from snrmon.acquisition.report.stop_csv import write_csv

    out = output_file(args.out, "-o/--out", suffixes=tuple(FORMATS))
    src = session_file(args.session, with_frames=True)
    if args.csv:
        output_file(args.csv, "--csv", suffixes=(".csv",))
    with frame_progress("replay") as progress:  # a bar on a terminal only
        data = report_data(src, target=args.target, progress=progress, noise=args.noise)
    render_report(data, out, paper_curves=not args.no_paper_curves)
    if args.csv:
        write_csv(data.csv_rows, args.csv)
    if args.json:
        return emit_json({"report": str(out), "stop_rows": len(data.flight.rows), "csv": args.csv})
    say(f"report: {out} ({len(data.flight.rows)} stop rows)")
    if args.csv:
        say(f"table: {args.csv}")
    return 0
