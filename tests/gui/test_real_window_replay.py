"""Replay controls in a real window (Xvfb, xdotool's X events): any sequence of play, pause,
step, seek and speed, forward and back, leaves the console running and its table whole.

The recording: three stops flown by both cameras (:func:`snrmon.examples.example_session`,
written by the real recorder; 2 MB), so that stepping and seeking back happens once each
camera has two stops, where the range plot's error bars used to be cleared with x and y only
(pyqtgraph kept the old error arrays beside the empty ones and the process died of a
segmentation fault at the next paint).
"""

from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from snrmon.examples import example_session
from snrmon.gui.replay_bar import SPEEDS
from tests.gui.test_real_window import click, console_env, poll
from tests.gui.test_real_window_layout import press

pytestmark = pytest.mark.desktop
STOPS_M = (37.0, 126.0, 199.0)
KEYS = {  # the replay's shortcuts (snrmon.gui.actions), as xdotool names them
    "play/pause": "space",
    "step": "Right",
    "back": "Left",
    "home": "Home",
    "faster": "bracketright",
    "slower": "bracketleft",
}


@pytest.fixture(scope="module")
def flight(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("real-replay") / "flight.h5"
    example_session(path, ranges_m=STOPS_M, hover_s=4.0, transit_s=1.0, fps=10.0)
    return path


def stops_per_camera(st: dict) -> dict[str, int]:
    out: dict[str, int] = {}
    for row in st["stops"]:
        out[row[1]] = out.get(row[1], 0) + 1  # the table's second column: the camera
    return out


def two_stops_each(status: Path, proc) -> dict:
    """The first status with the window shown and two stops of each camera in the table."""
    return poll(
        status,
        lambda s: s["window"]["visible"] and min(stops_per_camera(s).values(), default=0) >= 2,
        120,
        "two stops per camera",
        proc,
    )


def drag(display: str, start: list[int], end_x: int) -> None:
    """Press on ``start``, move along to ``end_x``, release: a hand dragging the slider."""
    env = {**os.environ, "DISPLAY": display}
    x, y = start
    # at a hand's pace (xdotool's own pauses between the steps): pressed and moved at once,
    # Qt sees the move before the press has grabbed the handle, and nothing is dragged
    cmd = ["xdotool", "mousemove", "--sync", str(x), str(y), "sleep", "0.2", "mousedown", "1"]
    cmd += ["sleep", "0.2", "mousemove", "--sync", str((x + end_x) // 2), str(y), "sleep", "0.2"]
    cmd += ["mousemove", "--sync", str(end_x), str(y), "sleep", "0.2", "mouseup", "1"]
    subprocess.run(cmd, env=env, check=True, timeout=30)


def answered(path: Path, proc, what: str) -> dict:
    """The first status written after now: the console's event loop ran past the command."""
    sent = time.time()
    return poll(path, lambda s: s["t_unix"] > sent, 30, f"the console after {what}", proc)


def console(display: str, flight: Path, tmp_path: Path, speed: str, *more: str):
    """``snrmon gui --replay flight`` at ``speed`` on ``display`` (``more``: further options),
    its status file in ``tmp_path``; (process, status file)."""
    status = tmp_path / "status.json"
    env = console_env(display, tmp_path)
    cmd = [sys.executable, "-m", "snrmon", "gui", "--replay", str(flight), "--speed", speed]
    cmd += ["--status-file", str(status), "--duration", "600", *more]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return proc, status


def closed(proc) -> str:
    proc.send_signal(signal.SIGTERM)
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    return err


@pytest.fixture
def display(xvfb_screens):
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool not installed (apt-get install xdotool; .ci/run does)")
    return xvfb_screens("1366x768")


def test_the_issue_s_sequence_back_after_two_stops_each(display, flight, tmp_path):
    """Speed 8, each camera two stops, click the table, Space, Right, Right, Left."""
    proc, status = console(display, flight, tmp_path, "8")
    try:
        st = two_stops_each(status, proc)
        click(display, *st["stop_table_screen"])
        for key in ("space", "Right", "Right", "Left"):
            press(display, key)
            st = answered(status, proc, key)
        assert not st["replay"]["playing"]  # Space paused it, the steps kept it paused
        back = st["replay"]["index"]
        press(display, "Left")
        st = poll(status, lambda s: s["replay"]["index"] == back - 1, 30, "Left once more", proc)
        assert set(stops_per_camera(st)) == {"mwir", "lwir"}
    finally:
        err = closed(proc)
    assert proc.returncode == 0, err
    assert "ErrorBarItem" not in err and "broadcast" not in err, err


@pytest.mark.slow
def test_fifty_random_replay_commands_leave_the_console_running(display, flight, tmp_path):
    rng = random.Random(35)
    proc, status = console(display, flight, tmp_path, "16")
    done: list[str] = []
    try:
        st = two_stops_each(status, proc)
        length = st["replay"]["length"]
        for _ in range(50):
            what = rng.choice([*KEYS, "seek", "seek"])
            if what == "seek":
                left, right, _y = st["replay"]["slider"]["groove"]
                to = rng.randrange(left, right + 1)
                drag(display, st["replay"]["slider"]["handle"], to)
                what = f"seek to x={to}"
            else:
                press(display, KEYS[what])
            done.append(what)
            st = answered(status, proc, " then ".join(done[-3:]))
            assert 0 <= st["replay"]["index"] < length
        # and the day plays from its start to its end again, every stop of both cameras back
        # in the table (a seek measures afresh from where it lands: the start, here)
        if answered(status, proc, "the last command")["replay"]["playing"]:
            press(display, KEYS["play/pause"])  # paused first: playing on, it would leave the start
            poll(status, lambda s: not s["replay"]["playing"], 30, "the pause", proc)
        press(display, KEYS["home"])
        poll(status, lambda s: s["replay"]["index"] == 0, 30, "the start", proc)
        for _ in range(len(SPEEDS)):
            press(display, KEYS["faster"])
        st = answered(status, proc, "the fastest speed")
        assert st["replay"]["speed"] == SPEEDS[-1]
        if not st["replay"]["playing"]:
            press(display, KEYS["play/pause"])
            poll(
                status,
                lambda s: s["replay"]["playing"] or s["replay"]["index"] == length - 1,
                30,
                "play",
                proc,
            )
        every = {"mwir": len(STOPS_M), "lwir": len(STOPS_M)}
        end = poll(  # the table refreshes on its own timer: it may follow the end by a moment
            status,
            lambda s: not s["replay"]["playing"] and stops_per_camera(s) == every,
            120,
            "the replay's end with every stop in the table",
            proc,
        )
        assert end["replay"]["index"] == length - 1
    finally:
        err = closed(proc)
    assert proc.returncode == 0, f"after {done}: {err}"
    assert "ErrorBarItem" not in err and "Traceback" not in err, f"after {done}: {err}"
    assert any(d.startswith("seek") for d in done) and "back" in done and "step" in done
