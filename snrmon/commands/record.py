"""``snrmon record``: a headless recording of the devices in a session config."""

from __future__ import annotations

import argparse
import shutil
import sys
import time

from snrmon.cli import UsageError
from snrmon.commands.recording_options import add_compression_option, with_compression
from snrmon.inputs import input_file, output_file
from snrmon.progress import status_progress


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("record", help="record the devices of a session config, headless")
    p.add_argument("--config", required=True, metavar="FILE.toml", help="session config")
    p.add_argument("--out", required=True, metavar="FILE.h5", help="new session file")
    add_compression_option(p)
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help="stop after S seconds (default: until Ctrl-C)",
    )
    p.add_argument(
        "--roi",
        action="append",
        default=[],
        metavar="CAMERA:X,Y",
        help="set a camera's ROI at start (repeatable)",
    )
    p.set_defaults(func=run)


def _roi(text: str) -> tuple[str, int, int]:
    try:
        cam, xy = text.split(":", 1)
        x, y = (int(v) for v in xy.split(","))
    except ValueError:
        raise UsageError(f"--roi must be CAMERA:X,Y, got {text!r}") from None
    return cam, x, y


def progress_line(session, t0: float) -> str:
    """Elapsed time, frames and drops per camera, MB written and disk free."""
    st = session.status()
    parts = [f"{time.monotonic() - t0:6.1f} s"]
    for name, cam in st.cameras.items():
        f = cam.frames
        drops = f.dropped_by_camera + f.dropped_by_ring + f.dropped_by_recorder
        parts.append(f"{name} {f.recorded} frames {drops} dropped")
    rec = st.recording
    free = f"{rec.free_bytes / 2**30:.1f} GB free" if rec.free_bytes is not None else ""
    parts.append(f"{rec.bytes_written / 2**20:.0f} MB written {free}".strip())
    if st.alarms:
        parts.append("ALARM " + "; ".join(st.alarms))
    return " | ".join(parts)


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.config import load_session_config
    from snrmon.acquisition.runtime.session import Session

    if args.duration is not None and not args.duration > 0:
        raise UsageError(f"--duration must be positive, got {args.duration}")
    out = output_file(args.out, "--out", suffixes=(".h5",), new=True)
    rois = [_roi(r) for r in args.roi]
    config = load_session_config(input_file(args.config, "--config"))
    config = with_compression(config, args.compression)
    session = Session(config)
    session.start()
    try:
        for cam, x, y in rois:
            session.set_roi(cam, x, y)
        session.start_recording(out)
        t0 = time.monotonic()
        with status_progress(args.duration, "recording") as show:
            while args.duration is None or time.monotonic() - t0 < args.duration:
                show(time.monotonic() - t0, progress_line(session, t0))
                if session.status().recording.state == "failed":
                    break
                time.sleep(0.5)  # the progress line's refresh rate
    except KeyboardInterrupt:
        pass
    finally:
        summary = session.stop_recording()
        session.stop()
    if summary is not None:
        print(
            f"recorded {out}: "
            + ", ".join(f"{n} {c} frames" for n, c in summary.frames_written.items())
        )
        if summary.error:
            print(f"recording stopped early: {summary.error}", file=sys.stderr)
            return 1
    print(f"free disk after: {shutil.disk_usage(out.parent).free / 2**30:.1f} GB", file=sys.stderr)
    return 0
