"""``snrmon doctor``: is this machine, with this session config, ready to fly? (the go/no-go)

    snrmon doctor [--config session.toml] [--record-dir DIR] [--duration S] [--json]
    snrmon doctor --template > session.toml


One line per check, PASS / FAIL / WARN / SKIP, and under each failure the fix. Exit 0 only when
every check the session needs passes (1 otherwise; 2 for a bad config or option). The checks
are :mod:`snrmon.doctor`'s. JSON contract (``--json``)::

    {"ok": bool, "config": str | null,
     "checks": [{"name", "status": "pass"|"fail"|"skip", "label": "PASS"|"FAIL"|"WARN"|"SKIP",
                 "needed": bool, "detail": str, "fix": str, "data": {...}}, ...]}
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

from snrmon.cli import EXIT_FAILURE, EXIT_OK, UsageError
from snrmon.inputs import input_file
from snrmon.output import emit_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "doctor",
        help="go/no-go before a flight: display, ports, backends, devices, disk",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE.toml",
        help="the session config to check (without it: this machine only)",
    )
    p.add_argument(
        "--record-dir",
        type=Path,
        default=Path("."),
        metavar="DIR",
        help="where the recordings will go (default: %(default)s)",
    )
    p.add_argument(
        "--duration",
        type=float,
        default=3600.0,
        metavar="S",
        help="planned recording, for the free-space check (default: %(default)s)",
    )
    p.add_argument(
        "--wait",
        type=float,
        default=5.0,
        metavar="S",
        help="how long each device may take to answer (default: %(default)s)",
    )
    p.add_argument(
        "--disk-test-mb",
        type=int,
        default=256,
        metavar="MB",
        help="how much to write when measuring the disk (default: %(default)s)",
    )
    p.add_argument(
        "--headless",
        action="store_true",
        help="the session runs without a window (snrmon record): the display is not needed",
    )
    p.add_argument(
        "--template",
        action="store_true",
        help="print a session config with every key, its default and what it expects, and exit",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.template:
        from snrmon.acquisition.config import session_template

        print(session_template(), end="")
        return EXIT_OK
    from snrmon.doctor import all_needed_pass
    from snrmon.doctor.runner import DoctorOptions, run_doctor

    for option, value in (("--duration", args.duration), ("--wait", args.wait)):
        if not value > 0:
            raise UsageError(f"{option} must be positive, got {value}")
    if args.disk_test_mb < 1:
        raise UsageError(f"--disk-test-mb must be >= 1, got {args.disk_test_mb}")
    if not args.record_dir.is_dir():
        raise FileNotFoundError(f"--record-dir {args.record_dir} is not a folder")
    config = None
    if args.config is not None:
        from snrmon.acquisition.config import load_session_config

        config = load_session_config(input_file(args.config, "--config"))
    opts = DoctorOptions(
        record_dir=args.record_dir,
        duration_s=args.duration,
        wait_s=args.wait,
        disk_test_bytes=args.disk_test_mb * 10**6,
        headless=args.headless,
    )
    checks = run_doctor(config, opts)
    ok = all_needed_pass(checks)
    if args.json:
        emit_json(
            {
                "ok": ok,
                "config": str(args.config) if args.config is not None else None,
                "checks": [
                    {
                        "name": c.name,
                        "status": c.status,
                        "label": c.label,
                        "needed": c.needed,
                        "detail": c.detail,
                        "fix": c.fix,
                        "data": c.data,
                    }
                    for c in checks
                ],
            }
        )
        return EXIT_OK if ok else EXIT_FAILURE
    for c in checks:
        print(f"{c.label:4s}  {c.name:14s} {c.detail}")
        if c.fix and c.label in ("FAIL", "WARN"):
            fix = textwrap.fill(c.fix, 96, initial_indent="      fix: ", subsequent_indent=" " * 11)
            print(fix)
    failed = [c.name for c in checks if c.label == "FAIL"]
    verdict = "ready" if ok else f"NOT ready: {', '.join(failed)}"
    print(f"snrmon doctor: {len(checks)} checks, {verdict}")
    return EXIT_OK if ok else EXIT_FAILURE
