"""``snrmon replay``: a recorded session through the same measurement, and its stop table."""

from __future__ import annotations

import argparse
import math

from snrmon.cli import UsageError
from snrmon.commands.measure import _point
from snrmon.inputs import is_session_recording
from snrmon.output import emit_json
from snrmon.progress import frame_progress, say


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="measure a recorded session again and rebuild its stops")
    p.add_argument(
        "recording",
        metavar="RECORDING",
        help="a snrmon session file (.h5), or another tool's recording (multi-page TIFF, .ptw, "
        "FLIR .seq/.csq/.fff/.jpg, raw file with FILE.json, video, .npy) measured from --at",
    )
    p.add_argument(
        "--at",
        type=_point,
        metavar="X,Y",
        help="where the drone is in the first frame (needed for recordings that are not "
        "snrmon sessions: they carry no ROI events)",
    )
    pace = p.add_mutually_exclusive_group()
    pace.add_argument(
        "--speed", type=float, metavar="X", help="pace to the recorded clock (1 = real time)"
    )
    pace.add_argument(
        "--fast",
        action="store_true",
        help="read only the pixels around the track from the file (same results, far faster)",
    )
    p.add_argument(
        "--tracking",
        choices=("recorded", "on", "off"),
        default="recorded",
        metavar="recorded|on|off",
        help="follow the drone as the recording did, or force tracking on/off "
        "(default: %(default)s)",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def _replay_foreign(args: argparse.Namespace) -> int:
    """Another tool's recording: no ROI events, no range streams. The same tracked Eq. (4)
    measurement as ``snrmon measure --track`` from the operator's ``--at``."""
    from snrmon.commands import measure

    if args.at is None:
        raise UsageError(
            f"{args.recording} is not a snrmon session: give --at X,Y (the drone's pixel)"
        )
    ns = argparse.Namespace(
        stack=args.recording,
        at=args.at,
        search=11,
        box=7,
        background="rim",
        detrend=False,
        window_frames=100,
        saturation=None,
        json=args.json,
        track=args.tracking != "off",
    )
    return measure.run(ns)


def _finite(v):
    """A number for strict JSON: None where it is not finite (nothing measured)."""
    return v if v is None or not isinstance(v, float) or math.isfinite(v) else None


def result_json(result) -> dict:
    """The replay as one strict-JSON object: the stop table, per camera the file's own frame
    accounting (:data:`~snrmon.acquisition.engine.status.ACCOUNTING_FIELDS`) and beside it what
    the replay did (frames in the file, measured again, taken from their recorded measurement,
    rows from before the recording's first frame), the comparison with the recording."""
    stops = [
        {
            "camera": r.camera,
            "stop": r.stop,
            "lrf_range_m": _finite(r.place.lrf_range_m),
            "gps_range_m": _finite(r.place.gps_range_m),
            "n_frames": r.reading.n_frames,
            "complete": r.reading.complete,
            "final": r.final,
            "measured_snr_mean": _finite(r.reading.snr_mean),
            "measured_snr_std": _finite(r.reading.snr_std),
            "measured_snr_sem": _finite(r.reading.snr_sem),
            "background": r.reading.background or None,
            "expected_eq4_rule": r.expected_eq4_rule,
            "model_snr": {k: _finite(v) for k, v in r.model.model_snr.items()},
            "resolved": r.model.resolved,
            "note": None if r.reading.n_frames else "no valid frame of this camera during the stop",
        }
        for r in result.stops
    ]
    from snrmon.acquisition.engine.status import FrameAccounting

    frames = {}
    for n, c in result.cameras.items():
        t = c.tally
        # The live frame accounting the file keeps, by its names (FrameAccounting: received =
        # written + sum(dropped) + before_recording + after_recording + queued + wrong_shape);
        # a file without it: its frames and the recorder's drops, the rest null. Beside it,
        # what the replay did, by names of its own.
        kept = (
            FrameAccounting.not_kept(c.n_frames, c.dropped)
            if c.accounting is None
            else c.accounting.as_record()
        )
        frames[n] = {
            **kept,
            "in_file": c.n_frames,
            "measured": t.measured,
            "from_recorded_rows": t.not_in_file,
            "rows_before_recording": t.before_recording,
            "compared": t.compared,
            "identical": t.identical,
            "first_difference_counter": t.first_difference,
            "states_restored": t.states_restored,
        }
    return {
        "format_version": result.format_version,
        "stops": stops,
        "stops_recorded": len(result.recorded_rows),
        "stops_identical": result.stops_identical,
        "frames": frames,
        "realtime_factor": _finite(result.realtime_factor),
        "processes": result.processes,
    }


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.replay.batch import replay_session

    if not is_session_recording(args.recording):
        return _replay_foreign(args)
    if args.at is not None:
        raise UsageError(
            f"--at is for recordings that are not snrmon sessions; {args.recording} is a session "
            "(it carries the operator's clicks)"
        )
    if args.speed is not None and not args.speed > 0:
        raise UsageError(f"--speed must be positive, got {args.speed}")
    with frame_progress("replay") as progress:  # a bar on a terminal only
        result = replay_session(
            args.recording,
            speed=args.speed,
            fast=args.fast,
            track={"recorded": None, "on": True, "off": False}[args.tracking],
            progress=progress,
        )
    out = result_json(result)
    if args.json:
        return emit_json(out)
    for n, c in out["frames"].items():
        dropped = ", ".join(f"{k} {v}" for k, v in c["dropped"].items() if v) or "none"
        print(
            f"{n}: {c['in_file']} frames in the file (dropped while recording: {dropped}); "
            f"{c['identical']}/{c['compared']} per-frame SNRs identical to the recorded ones"
            + (
                f"; {c['from_recorded_rows']} taken from their recorded rows"
                if c["from_recorded_rows"]
                else ""
            )
        )
    if out["stops_identical"] is not None:
        print(
            f"stops: {out['stops_identical']}/{out['stops_recorded']} identical to the live table"
        )
    for s in out["stops"]:
        rng = s["lrf_range_m"] if s["lrf_range_m"] is not None else s["gps_range_m"]
        snr, std = s["measured_snr_mean"], s["measured_snr_std"]
        print(
            f"{s['camera']:6s} range {rng if rng is not None else math.nan:7.1f} m  "
            f"n {s['n_frames']:4d}  SNR {snr if snr is not None else math.nan:7.2f} "
            f"+/- {std if std is not None else math.nan:5.2f}"
        )
    say(f"replayed at {result.realtime_factor:.1f}x real time")
    return 0
