"""The console's screenshots in README.md and docs/console.md, taken afresh from today's build.

    python tools/console_screenshots.py            # docs/images/console-1366x768.png, -1920x1080
    python tools/console_screenshots.py --sizes 1920x1080 --stops 3

Each screen size gets its own real X server (Xvfb) and a first start of ``snrmon demo`` on it
(no saved settings: the window fills the screen, as an operator's first start does), the live
simulated day with both cameras. Once the stop table holds ``--stops`` stops of each camera (read
from the console's status file) the console is closed as Ctrl-C closes it and saves its window
(``--screenshot``). The PNG is then stored with an adaptive palette (the camera images' noise
keeps a full-colour PNG over 700 kB at 1920x1080), fewer colours until it is under
:data:`MAX_BYTES`.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT_DIR = ROOT / "docs" / "images"
SIZES = ("1366x768", "1920x1080")
MAX_BYTES = 300_000
COLOURS = (256, 192, 128, 96, 64)
TIMEOUT_S = 600.0  # the rig's start and a loaded machine's slow day


def stops_per_camera(status: dict) -> dict[str, int]:
    """The stop table's rows per camera (its second column), from the status file."""
    out: dict[str, int] = {}
    for row in status.get("stops", []):
        out[row[1]] = out.get(row[1], 0) + 1
    return out


def _status(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None  # not written yet


def raw_screenshot(size: str, stops: int, out: Path, tmp: Path) -> dict:
    """``snrmon demo`` on an Xvfb screen of ``size``, closed once each camera has ``stops``
    stops in the table, its window saved to ``out``; the last status the console wrote."""
    sys.path.insert(0, str(ROOT))
    from snrmon.benchmarks.xvfb import start_xvfb

    status = tmp / f"status-{size}.json"
    with start_xvfb(size) as xvfb:
        env = {
            **os.environ,
            "DISPLAY": xvfb.display,
            "QT_QPA_PLATFORM": "xcb",
            "XDG_CONFIG_HOME": str(tmp / f"config-{size}"),  # a first start: nothing saved
        }
        cmd = [sys.executable, "-m", "snrmon", "demo", "--screenshot", str(out)]
        cmd += ["--status-file", str(status)]
        proc = subprocess.Popen(cmd, env=env, cwd=tmp, stdout=subprocess.DEVNULL)
        deadline = time.monotonic() + TIMEOUT_S
        last = None
        while proc.poll() is None:
            last = _status(status) or last
            per_camera = stops_per_camera(last or {})
            if len(per_camera) == 2 and min(per_camera.values()) >= stops:
                proc.send_signal(signal.SIGINT)  # the console closes and saves its window
                break
            if time.monotonic() > deadline:
                proc.kill()
                raise RuntimeError(f"{size}: {stops} stops per camera not reached in time")
            time.sleep(0.5)  # the status file's pace (5 a second), not synchronisation
        if proc.wait(TIMEOUT_S) != 0:
            raise RuntimeError(f"{size}: snrmon demo exited with {proc.returncode}")
    if last is None or not out.exists():
        raise RuntimeError(f"{size}: no screenshot was saved")
    return last


def small_png(raw: Path, out: Path) -> int:
    """``raw`` stored at ``out`` with the most palette colours (:data:`COLOURS`) that keep it
    under :data:`MAX_BYTES`; its size in bytes."""
    from PIL import Image

    image = Image.open(raw).convert("RGB")
    data = b""
    for colours in COLOURS:
        buf = io.BytesIO()
        image.quantize(colours, method=Image.Quantize.MEDIANCUT).save(buf, "PNG", optimize=True)
        data = buf.getvalue()
        if len(data) <= MAX_BYTES:
            break
    out.write_bytes(data)
    return len(data)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default=",".join(SIZES), help="comma-separated WxH screens")
    p.add_argument("--stops", type=int, default=2, help="stops of each camera in the table")
    p.add_argument("--out-dir", type=Path, default=OUT_DIR)
    args = p.parse_args(argv)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="snrmon-screenshots-") as tmp:
        for size in args.sizes.split(","):
            raw = Path(tmp) / f"raw-{size}.png"
            status = raw_screenshot(size, args.stops, raw, Path(tmp))
            out = args.out_dir / f"console-{size}.png"
            n = small_png(raw, out)
            w = status["window"]
            print(
                f"{out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}: {n} bytes, "
                f"window {w['width']}x{w['height']}, stops {stops_per_camera(status)}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
