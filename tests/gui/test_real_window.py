"""The console as a person uses it: a real window on a real X server (Xvfb, Qt's xcb platform),
the mouse moved and clicked by xdotool (X events, not Qt calls), and what the console then
shows read back from its status file (``snrmon gui --status-file``).

A simulated camera writes a drone (a bright spot) on noise. The test clicks empty sky first: the
ROI moves there and the console says the click found no object (and, if the track's search then
settles on the drone, where and how far from the click). Then the drone: the measured peak lands
on it and the readout shows its SNR. Every wait polls the status file against a deadline.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from snrmon.sim.devices.shm_camera import ShmProducer
from tests.helpers import SPOT_X, SPOT_Y, SpotOnNoise, sensor_toml

pytestmark = pytest.mark.desktop
REPO = Path(__file__).resolve().parents[2]


def _status(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None  # not written yet


def poll(path: Path, predicate, timeout_s: float, what: str, proc) -> dict:
    """The first status for which ``predicate`` holds (a deadline, not a sleep: the file is
    rewritten five times a second)."""
    deadline = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            _, err = proc.communicate()
            pytest.fail(f"the console exited ({proc.returncode}) waiting for {what}: {err}")
        st = _status(path)
        if st is not None:
            last = st
            if predicate(st):
                return st
        time.sleep(0.05)  # polling interval of the file, not synchronisation
    pytest.fail(f"timed out after {timeout_s} s waiting for {what}; last status: {last}")


def screen_point(cam: dict, x: int, y: int) -> tuple[int, int]:
    """Where image pixel (x, y)'s centre is on the screen, from where the console says its
    first and last pixels are (zoom and pan included)."""
    (x0, y0), (x1, y1) = cam["screen_first_pixel"], cam["screen_last_pixel"]
    rows, cols = cam["shape"]
    return round(x0 + x * (x1 - x0) / (cols - 1)), round(y0 + y * (y1 - y0) / (rows - 1))


def console_env(display: str, tmp_path: Path) -> dict[str, str]:
    """The environment of a console in a real window on ``display``: Qt's xcb platform, the
    checkout importable, and a settings folder of its own (a first start: nothing saved)."""
    return {
        **os.environ,
        "DISPLAY": display,
        "QT_QPA_PLATFORM": "xcb",
        "XDG_CONFIG_HOME": str(tmp_path / "config"),
        "PYTHONPATH": str(REPO),
    }


def console_process(
    config: Path, display: str, folder: Path, *extra: str, theme: str = "dark"
) -> tuple[subprocess.Popen, Path]:
    """``snrmon gui --config config`` in a real window on ``display`` (a first start, its
    settings under ``folder``), writing its status file ``folder/status.json``: the process and
    that file. It closes by itself after 600 s; the tests end it sooner."""
    status = folder / "status.json"
    cmd = [sys.executable, "-m", "snrmon", "gui", "--config", str(config), *extra]
    cmd += ["--status-file", str(status), "--duration", "600", "--theme", theme]
    proc = subprocess.Popen(
        cmd,
        env=console_env(display, folder),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    return proc, status


def click(display: str, x: int, y: int) -> None:
    env = {**os.environ, "DISPLAY": display}
    subprocess.run(
        ["xdotool", "mousemove", "--sync", str(x), str(y), "click", "1"],
        env=env,
        check=True,
        timeout=30,
    )


@pytest.mark.slow
def test_clicking_the_drone_in_the_real_window(xvfb_display, tmp_path):
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool not installed (apt-get install xdotool; .ci/run does)")
    ring = f"snrmon-win-{os.getpid()}"
    producer = ShmProducer(ring, 128, 96, SpotOnNoise(5), fps=60.0, slots=16)
    sensor = sensor_toml(tmp_path / "sensor.toml")
    config = tmp_path / "session.toml"
    config.write_text(f'[cameras.cam]\nsource = "shm"\naddress = "{ring}"\nsensor = "{sensor}"\n')
    status = tmp_path / "status.json"
    env = console_env(xvfb_display, tmp_path)
    cmd = [
        sys.executable,
        "-m",
        "snrmon",
        "gui",
        "--config",
        str(config),
        "--status-file",
        str(status),
        "--duration",
        "300",
    ]
    producer.start()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        st = poll(
            status,
            lambda s: s["window"]["visible"] and s["cameras"]["cam"]["frames_shown"] > 10,
            90,
            "the window showing frames",
            proc,
        )
        assert st["cameras"]["cam"]["roi"] is None and st["cameras"]["cam"]["snr_mean"] is None

        # 1. Empty sky, far from the drone: the ROI goes where the hand clicked and the console
        # says there is no object there (docs/tracking.md: the track is lost, reason no_object,
        # and searches outward from the click). The drone is the only object in view: when the
        # search settles on it, the console says so and how far from the click it is.
        click(xvfb_display, *screen_point(st["cameras"]["cam"], 20, 70))
        nothing = "cam: no object at the click (column 20, row 70): the track searches around it"
        sky = poll(
            status,
            lambda s: (
                "cam: ROI set at column 20, row 70" in s["messages"] and nothing in s["messages"]
            ),
            30,
            "the console saying the click found no object",
            proc,
        )
        sky_cam = sky["cameras"]["cam"]
        assert sky["messages"].index(nothing) > sky["messages"].index(
            "cam: ROI set at column 20, row 70"
        )
        found = [m for m in sky["messages"] if m.startswith("cam: the track found an object")]
        for m in found:  # only ever the drone (its peak pixel: noise may pick either of the
            # two rows the spot straddles), and never silently
            where = re.match(r"cam: the track found an object at column (\d+), row (\d+), ", m)
            assert where, m
            assert abs(int(where[1]) - SPOT_X) < 1 and abs(int(where[2]) - SPOT_Y) < 1, m

        # 2. The drone (a pixel off its peak, as a hand would): the ROI moves to the click, the
        # measurement's peak lands on the drone and the readout becomes the drone's SNR.
        x, y = round(SPOT_X) - 1, round(SPOT_Y) + 1
        click(xvfb_display, *screen_point(sky_cam, x, y))
        drone = poll(
            status,
            lambda s: (
                f"cam: ROI set at column {x}, row {y}" in s["messages"]
                and s["cameras"]["cam"]["peak"] == [round(SPOT_X), round(SPOT_Y)]
                and (s["cameras"]["cam"]["snr_n"] or 0) >= 5
            ),
            30,
            "the ROI on the drone",
            proc,
        )
        cam = drone["cameras"]["cam"]
        assert cam["track_state"] == "tracking"
        # The drone's SNR (its amplitude over the noise, far above any noise peak's, about 3),
        # and the readout the operator sees shows it.
        assert cam["snr_mean"] > 8
        assert f"SNR(100) ± error {cam['snr_mean']:.2f} ± " in cam["header"], cam["header"]
        # A click on the drone itself needs no word from the track.
        assert f"cam: no object at the click (column {x}, row {y})" not in " ".join(
            drone["messages"]
        )
    finally:
        proc.send_signal(signal.SIGTERM)  # the console closes its window on SIGTERM
        try:
            _, err = proc.communicate(timeout=30)
        finally:
            proc.kill()
            producer.stop()
    assert proc.returncode == 0, err
