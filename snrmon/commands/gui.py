"""``snrmon gui``: the operator console on the devices of a session TOML file."""

from __future__ import annotations

import argparse
from pathlib import Path

from snrmon.cli import UsageError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("gui", help="the operator console on real devices (session TOML)")
    p.add_argument("--config", type=Path, help="session TOML file (cameras, lrf, gps, site)")
    p.add_argument("--replay", type=Path, help="open a recorded session file (not yet available)")
    p.add_argument("--headless", action="store_true", help="run offscreen (no display needed)")
    p.add_argument("--duration", type=float, help="close after this many seconds")
    p.add_argument("--screenshot", type=Path, help="save the window to this PNG at the end")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.replay is not None:
        raise UsageError("snrmon gui --replay: replay is not yet available in the console")
    if args.config is None:
        raise UsageError("snrmon gui needs --config FILE.toml (or --replay FILE.h5)")
    from acquisition.prediction import ModelPredictor
    from acquisition.session import Session
    from acquisition.session_config import load_session_config
    from gui.app import run_console

    config = load_session_config(args.config)
    predictor = ModelPredictor({c.name: c.sensor for c in config.cameras}, config.target)
    with Session(config, predictor=predictor) as session:
        return run_console(
            session,
            curves=predictor.curve,
            headless=args.headless,
            duration_s=args.duration,
            screenshot=args.screenshot,
        )
