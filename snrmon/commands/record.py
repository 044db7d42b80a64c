"""``snrmon record``: a headless recording of the devices in a session config.

With ``--json`` the result is one object on stdout: ``{"file", "frames_written": {camera: n},
"frames": {camera: the frame accounting},
"error" (why the recording stopped early, or null), "devices_lost" (each device lost with its
times), "free_bytes" (the disk's after)}``; a lost device or an early stop still ends with
exit 1 and its one error line.
"""

from __future__ import annotations

import argparse
import shutil
import time

from snrmon.cli import UsageError
from snrmon.commands.recording_options import add_compression_option, with_compression
from snrmon.inputs import duration_s, input_file, output_file
from snrmon.output import emit_json
from snrmon.progress import say, status_progress


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("record", help="record the devices of a session config, headless")
    p.add_argument("--config", required=True, metavar="FILE.toml", help="session config")
    p.add_argument("-o", "--out", required=True, metavar="PATH", help="new session file (.h5)")
    add_compression_option(p)
    p.add_argument(
        "--duration",
        type=duration_s(),
        default=None,
        metavar="S",
        help="stop after S seconds (default: until Ctrl-C)",
    )
    p.add_argument(
        "--click",
        action="append",
        metavar="CAMERA:X,Y",
        help="the operator's click at start: the camera's ROI at X,Y (repeat for each camera)",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def _click(text: str) -> tuple[str, int, int]:
    try:
        cam, xy = text.split(":", 1)
        x, y = (int(v) for v in xy.split(","))
    except ValueError:
        raise UsageError(f"--click must be CAMERA:X,Y, got {text!r}") from None
    return cam, x, y


def progress_line(session, t0: float) -> str:
    """Elapsed time, frames and drops per camera, MB written and disk free."""
    st = session.status()
    parts = [f"{time.monotonic() - t0:6.1f} s"]
    for name, cam in st.cameras.items():
        f = cam.frames
        parts.append(f"{name} {f.written} frames {f.lost} dropped")
    rec = st.recording
    free = f"{rec.free_bytes / 2**30:.1f} GB free" if rec.free_bytes is not None else ""
    parts.append(f"{rec.bytes_written / 2**20:.0f} MB written {free}".strip())
    if st.alarms:
        parts.append("ALARM " + "; ".join(st.alarms))
    return " | ".join(parts)


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.config import load_session_config
    from snrmon.acquisition.runtime.session import Session

    out = output_file(args.out, "--out", suffixes=(".h5",), new=True)
    rois = [_click(r) for r in args.click or ()]
    config = load_session_config(input_file(args.config, "--config"))
    session = Session(with_compression(config, args.compression))
    # The file is created (exclusively) before any device opens: a second writer onto the same
    # path is refused having opened no port and no camera.
    session.start_recording(out)
    summary = None
    try:
        session.start()
        # Every device the config names delivers within its start-up timeout, or the command
        # stops here (DeviceError: exit 1, naming it).
        session.wait_delivering()
        for cam, x, y in rois:
            session.set_roi(cam, x, y)
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
    free = shutil.disk_usage(out.parent).free
    if args.json:
        emit_json(
            {
                "file": str(out),
                "frames_written": dict(summary.frames_written),
                # the frame accounting by camera, as the file keeps it (FrameAccounting)
                "frames": summary.extra.get("accounting", {}),
                "error": summary.error or None,
                "devices_lost": [x.as_dict() for x in session.devices_lost()],
                "free_bytes": free,
            }
        )
    else:
        print(
            f"recorded {out}: "
            + ", ".join(f"{n} {c} frames" for n, c in summary.frames_written.items())
        )
    # One path for every failure (a device lost, the disk full): an error line, exit 1, after
    # the file is closed and the result printed.
    session.check_devices()
    if summary.error:
        raise OSError(summary.error)
    say(f"free disk after: {free / 2**30:.1f} GB")
    return 0
