"""``snrmon gui``: the operator console on the devices of a session TOML file.

Exit 0 when the window closes; 1 when a device was lost while it ran (a camera's process gone,
a port closed, a receiver silent), with one line naming each device and the time it was lost.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from snrmon.cli import UsageError
from snrmon.commands.recording_options import add_compression_option, with_compression
from snrmon.extras import require
from snrmon.inputs import duration_s, input_file, is_session_recording, output_file


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("gui", help="the operator console on real devices (session TOML)")
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE.toml",
        help="session config (cameras, lrf, gps, site)",
    )
    p.add_argument(
        "--replay",
        type=Path,
        metavar="RECORDING",
        help="replay a recorded session in the console, or another tool's recording (FLIR "
        ".seq/.csq/.fff/.jpg, .ptw, TIFF, ...), written as a session beside it first",
    )
    p.add_argument(
        "--sensor",
        metavar="mwir|lwir|FILE",
        help="with --replay of another tool's recording: its camera's sensor model (default: "
        "lwir for a FLIR file, mwir for a .ptw; needed for any other)",
    )
    p.add_argument("--headless", action="store_true", help="run offscreen (no display needed)")
    p.add_argument("--duration", type=duration_s(), metavar="S", help="close after S seconds")
    p.add_argument(
        "--screenshot", type=Path, metavar="FILE.png", help="save the window to this PNG at the end"
    )
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="X",
        help="with --replay: play at X times real time, 0.01 to 1000 (default: %(default)s)",
    )
    add_compression_option(p)
    add_status_file_option(p)
    add_view_options(p)
    p.set_defaults(func=run)


def add_view_options(p: argparse.ArgumentParser) -> None:
    """``--theme``, ``--font-scale`` and ``--window-size``, shared with ``snrmon demo``."""
    p.add_argument(
        "--theme",
        choices=("dark", "daylight"),
        metavar="dark|daylight",
        help="dark, or daylight (light background, high contrast); default: the last one used",
    )
    p.add_argument(
        "--font-scale",
        type=float,
        metavar="X",
        help="every text's size over normal, 0.8 to 2 (default: the last one used)",
    )
    p.add_argument(
        "--window-size",
        metavar="WxH",
        help="open the window at W x H pixels (default: the saved layout, or the whole screen "
        "at a first start; offscreen 1920x1080)",
    )


def window_size(text: str | None) -> tuple[int, int] | None:
    """``--window-size WxH`` as (width, height); None when not given."""
    if text is None:
        return None
    w, sep, h = text.lower().partition("x")
    try:
        size = (int(w), int(h))
    except ValueError:
        size = (0, 0)
    if not sep or not (200 <= size[0] <= 16384 and 200 <= size[1] <= 16384):
        raise UsageError(f"--window-size must be WxH in pixels (200 to 16384 each), got {text!r}")
    return size


def view_options(args: argparse.Namespace) -> dict:
    """The console's view arguments of ``run_console`` (checked: a bad one is exit 2)."""
    from snrmon.gui.theme import check_font_scale

    scale = args.font_scale
    if scale is not None:
        try:
            check_font_scale(scale)
        except ValueError as exc:
            raise UsageError(f"--font-scale: {exc}") from None
    return {"theme": args.theme, "font_scale": scale, "size": window_size(args.window_size)}


def add_status_file_option(p: argparse.ArgumentParser) -> None:
    """``--status-file``, shared with ``snrmon demo``."""
    p.add_argument(
        "--status-file",
        type=Path,
        metavar="FILE.json",
        help="keep the console's state (ROI, SNR readout, where each image is on the screen) "
        "in FILE.json, rewritten 5 times a second, for scripts and tests",
    )


def check_console_outputs(args: argparse.Namespace) -> None:
    """Before a window opens: the files it will write can be written."""
    if args.screenshot is not None:
        output_file(args.screenshot, "--screenshot", suffixes=(".png",))
    if args.status_file is not None:
        output_file(args.status_file, "--status-file", suffixes=(".json",))
    window_size(args.window_size)


def run(args: argparse.Namespace) -> int:
    require("gui", "the console")
    check_console_outputs(args)
    if args.replay is not None:
        if args.config is not None:
            raise UsageError("give --config FILE.toml or --replay FILE.h5, not both")
        if not 0.01 <= args.speed <= 1000.0:
            raise UsageError(f"--speed must be 0.01 to 1000 x real time, got {args.speed}")
        if is_session_recording(args.replay, "--replay"):
            if args.sensor is not None:
                raise UsageError(
                    f"--sensor is for another tool's recording; {args.replay} is a "
                    "session (it names its own sensors)"
                )
            return _run_replay(args, args.replay)
        return _replay_camera_file(args)
    if args.sensor is not None:
        raise UsageError("--sensor goes with --replay of another tool's recording")
    if args.config is None:
        raise UsageError("needs --config FILE.toml (or --replay FILE.h5)")
    input_file(args.config, "--config")
    from snrmon.acquisition.config import load_session_config
    from snrmon.acquisition.runtime.session import Session
    from snrmon.gui.app import run_console

    config = load_session_config(args.config)
    config = with_compression(config, args.compression)
    with Session(config, model_from_config=True) as session:  # the model its config names
        predictor = session.predictor
        code = run_console(
            session,
            curves=predictor.curve if predictor is not None else None,
            headless=args.headless,
            duration_s=args.duration,
            screenshot=args.screenshot,
            status_file=args.status_file,
            **view_options(args),
        )
        # a device lost during the session (even one that came back): the error line and
        # exit 1 once the window has closed, as `record` ends
        session.check_devices()
        return code


def _replay_camera_file(args: argparse.Namespace) -> int:
    """Another tool's recording, written as a session in a temporary folder (removed when the
    console closes) and replayed like one (:mod:`snrmon.acquisition.replay.stack_session`)."""
    import tempfile

    from snrmon.acquisition.replay.flir import FLIR_SUFFIXES
    from snrmon.acquisition.replay.stack_session import session_from_stack
    from snrmon.progress import say

    suffix = args.replay.suffix.lower()
    default = "lwir" if suffix in FLIR_SUFFIXES else "mwir" if suffix == ".ptw" else None
    sensor = args.sensor or default
    if sensor is None:
        raise UsageError(
            f"--replay {args.replay}: give --sensor (mwir, lwir or a sensor TOML): the file "
            "does not say which camera made it"
        )
    camera = sensor if sensor in ("mwir", "lwir") else "camera"
    with tempfile.TemporaryDirectory(prefix="snrmon-replay-") as folder:
        session = session_from_stack(
            args.replay, Path(folder) / "recording.h5", sensor=sensor, camera=camera
        )
        say(f"{args.replay}: replayed as camera {camera!r} with the {sensor} sensor model")
        return _run_replay(args, session)


def _run_replay(args: argparse.Namespace, path: Path) -> int:
    from snrmon.acquisition.replay.player import ReplayPlayer
    from snrmon.gui.app import run_console

    # the model the recording's config names (none without a camera's sensor)
    player = ReplayPlayer(path, speed=args.speed, model_from_config=True)
    predictor = player.predictor
    with player:
        player.play()  # the analyst sees it run at once; Space pauses
        return run_console(
            player,
            curves=predictor.curve if predictor is not None else None,
            headless=args.headless,
            duration_s=args.duration,
            screenshot=args.screenshot,
            status_file=args.status_file,
            **view_options(args),
        )
