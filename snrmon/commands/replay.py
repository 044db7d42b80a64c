"""``snrmon replay``: a recorded session through the same measurement, and its stop table."""

from __future__ import annotations

import argparse
import json
import math
import sys

from snrmon.cli import UsageError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="measure a recorded session again and rebuild its stops")
    p.add_argument(
        "file",
        metavar="FILE",
        help="a snrmon session file (.h5), or another tool's recording (multi-page TIFF, raw "
        "file with FILE.json, video, .npy) measured from --at",
    )
    p.add_argument(
        "--at",
        metavar="X,Y",
        help="where the drone is in the first frame (needed for recordings that are not "
        "snrmon sessions: they carry no ROI events)",
    )
    pace = p.add_mutually_exclusive_group()
    pace.add_argument("--speed", type=float, help="pace to the recorded clock (1 = real time)")
    pace.add_argument(
        "--fast",
        action="store_true",
        help="read only the pixels around the track from the file (same results, far faster)",
    )
    p.add_argument(
        "--track",
        choices=("recorded", "on", "off"),
        default="recorded",
        help="follow the drone as the recording did (default), or force tracking on/off",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def _is_session(path: str) -> bool:
    from pathlib import Path

    p = Path(path)
    if not p.exists():
        raise UsageError(f"{path} does not exist")
    with p.open("rb") as fh:
        return fh.read(8) == b"\x89HDF\r\n\x1a\n"


def _replay_foreign(args: argparse.Namespace) -> int:
    """Another tool's recording: no ROI events, no range streams. The same tracked Eq. (4)
    measurement as ``snrmon measure --track`` from the operator's ``--at``."""
    from snrmon.commands import measure

    if args.at is None:
        raise UsageError(f"{args.file} is not a snrmon session: give --at X,Y (the drone's pixel)")
    ns = argparse.Namespace(
        stack=args.file,
        at=measure._point(args.at),
        search=11,
        box=7,
        background="rim",
        detrend=False,
        window=100,
        saturation=None,
        json=args.json,
        track=args.track != "off",
    )
    return measure.run(ns)


def run(args: argparse.Namespace) -> int:
    from acquisition.replay.batch import replay_session

    if not _is_session(args.file):
        return _replay_foreign(args)
    if args.speed is not None and not args.speed > 0:
        raise UsageError(f"--speed must be positive, got {args.speed}")
    result = replay_session(
        args.file,
        speed=args.speed,
        fast=args.fast,
        track={"recorded": None, "on": True, "off": False}[args.track],
    )
    stops = [
        {
            "camera": r.camera,
            "planned_range_m": None,
            "lrf_range_m": r.lrf_range_m,
            "gps_range_m": r.gps_range_m,
            "n_frames": r.n_frames,
            "measured_snr_mean": r.snr_mean,
            "measured_snr_std": r.snr_std,
            "model_snr": r.model_snr,
            "resolved": r.resolved,
        }
        for r in result.stops
    ]
    frames = {
        n: {"received": c.n_frames, "dropped": 0, "identical": c.identical, "compared": c.compared}
        for n, c in result.cameras.items()
    }
    if args.json:
        print(
            json.dumps(
                {"stops": stops, "frames": frames, "realtime_factor": result.realtime_factor}
            )
        )
        return 0
    for n, c in result.cameras.items():
        print(
            f"{n}: {c.n_frames} frames, {c.identical}/{c.compared} per-frame SNRs identical "
            "to the recorded ones"
        )
    for s in stops:
        rng = s["lrf_range_m"] if s["lrf_range_m"] is not None else s["gps_range_m"]
        print(
            f"{s['camera']:6s} range {rng if rng is not None else math.nan:7.1f} m  "
            f"n {s['n_frames']:4d}  SNR {s['measured_snr_mean']:7.2f} "
            f"+/- {s['measured_snr_std']:5.2f}"
        )
    print(f"replayed at {result.realtime_factor:.1f}x real time", file=sys.stderr)
    return 0
