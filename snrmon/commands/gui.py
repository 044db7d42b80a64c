"""``snrmon gui``: the operator console on the devices of a session TOML file."""

from __future__ import annotations

import argparse
from pathlib import Path

from snrmon.cli import UsageError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("gui", help="the operator console on real devices (session TOML)")
    p.add_argument("--config", type=Path, help="session TOML file (cameras, lrf, gps, site)")
    p.add_argument(
        "--replay", type=Path, help="replay a recorded session file (FILE.h5) in the console"
    )
    p.add_argument("--headless", action="store_true", help="run offscreen (no display needed)")
    p.add_argument("--duration", type=float, help="close after this many seconds")
    p.add_argument("--screenshot", type=Path, help="save the window to this PNG at the end")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.replay is not None:
        if args.config is not None:
            raise UsageError("snrmon gui: give --config FILE.toml or --replay FILE.h5, not both")
        return _run_replay(args)
    if args.config is None:
        raise UsageError("snrmon gui needs --config FILE.toml (or --replay FILE.h5)")
    from acquisition.config import load_session_config
    from acquisition.prediction import ModelPredictor
    from acquisition.runtime.session import Session
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


def _run_replay(args: argparse.Namespace) -> int:
    from acquisition.prediction import ModelPredictor
    from acquisition.replay.player import ReplayPlayer
    from gui.app import run_console

    player = ReplayPlayer(args.replay)
    cfg = player.config
    predictor = None
    if cfg.cameras:  # the recording names its sensors and target: the model can run
        predictor = ModelPredictor({c.name: c.sensor for c in cfg.cameras}, cfg.target)
        player.set_predictor(predictor)
    with player:
        player.play()  # the analyst sees it run at once; Space pauses
        return run_console(
            player,
            curves=predictor.curve if predictor is not None else None,
            headless=args.headless,
            duration_s=args.duration,
            screenshot=args.screenshot,
        )
