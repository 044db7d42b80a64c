"""The console losing a device: ``snrmon gui`` on a simulated camera whose process is killed, and
``snrmon demo`` whose simulated MWIR camera process is killed mid-flight. Each logs the loss with
its time when it happens and ends, once its window closes, with exit 1 and one error line naming
the device, as ``record`` and ``hil`` do; the demo's result lists it in ``devices_lost``."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import psutil
import pytest

from snrmon.sim.devices.shm_camera import ShmProducer
from tests.gui.test_console import H, W, console_render

ROOT = Path(__file__).resolve().parents[2]
LOST = r"{cmd}: warning: {device} lost at \d{{4}}-\d\d-\d\dT[\d:.]+\+00:00 \(disconnected: .*died"


def _snrmon(argv: list[str], cwd: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT), QT_QPA_PLATFORM="offscreen")
    return subprocess.Popen(
        [sys.executable, "-m", "snrmon", *argv],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )


def _until_shown(proc: subprocess.Popen, status: Path, camera: str, timeout_s: float) -> None:
    """Until the console's status file shows frames of ``camera`` (the console is up and the
    camera streaming)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            if json.loads(status.read_text())["cameras"][camera]["frames_shown"] > 0:
                return
        except (OSError, ValueError, KeyError):
            pass  # not written yet
        if proc.poll() is not None:
            raise AssertionError(f"ended early: {proc.communicate()[1].decode(errors='replace')}")
        if time.monotonic() > deadline:
            raise AssertionError(f"no frame of {camera} shown within {timeout_s} s")
        time.sleep(0.2)  # polling another process's file: nothing to wait on


def _stderr_until(proc: subprocess.Popen, pattern: str) -> str:
    """stderr as it comes, up to a line matching ``pattern``."""
    seen = b""
    while not re.search(pattern, seen.decode(errors="replace")):
        chunk = os.read(proc.stderr.fileno(), 4096)
        assert chunk, f"stderr closed before {pattern!r}: {seen.decode(errors='replace')}"
        seen += chunk
    return seen.decode(errors="replace")


def _errors(err: str) -> list[str]:
    return [line for line in err.splitlines() if ": error: " in line]


@pytest.mark.slow
def test_the_console_that_lost_its_camera_ends_with_exit_1_naming_it(tmp_path):
    ring = f"snrmon-guilost-{uuid.uuid4().hex[:10]}"
    toml = tmp_path / "session.toml"
    toml.write_text(
        f'[cameras.cam]\nsource = "shm"\naddress = "{ring}"\nsensor = "mwir"\n'
        f"width_px = {W}\nheight_px = {H}\n"
    )
    status, log_file = tmp_path / "status.json", tmp_path / "gui.log"
    producer = ShmProducer(ring, W, H, console_render(4), fps=30.0, slots=16)
    producer.start()
    argv = ["gui", "--config", str(toml), "--headless", "--status-file", str(status)]
    proc = _snrmon([*argv, "--log-file", str(log_file)], tmp_path)
    try:
        _until_shown(proc, status, "cam", 300)
        producer.kill()
        seen = _stderr_until(proc, LOST.format(cmd="snrmon gui", device="cam"))
        proc.send_signal(signal.SIGTERM)  # the operator closes the window
        out, rest = proc.communicate(timeout=60)
    finally:
        proc.kill()
        proc.wait(10)
        producer.close()
    err = seen + rest.decode(errors="replace")
    assert proc.returncode == 1, err
    errors = _errors(err)
    assert len(errors) == 1 and errors[0].startswith("snrmon gui: error: cam lost at "), err
    assert f"frame ring '{ring}'" in errors[0] and "died" in errors[0]
    assert re.search(r"cam lost at \S+ \(disconnected: ", log_file.read_text())  # kept in the log
    assert out == b""


def _camera_process(parent: psutil.Process, camera: str) -> psutil.Process:
    """The child process writing ``camera``'s frame ring (the only child that maps it)."""
    for child in parent.children(recursive=True):
        try:
            if any(f"/snrmon-{camera}-" in m.path for m in child.memory_maps()):
                return child
        except psutil.Error:
            continue  # a child that ended meanwhile
    raise AssertionError(f"no child process writes {camera}'s ring")


@pytest.mark.slow
def test_the_demo_that_lost_a_camera_flies_on_and_ends_with_exit_1_naming_it(tmp_path):
    """The MWIR camera's process is killed once the console shows its frames: the loss is seen
    at once (the process ended, not the 15 s of silence a busy day allows), the day's clock no
    longer waits for that camera, so the LWIR camera, GPS and rangefinder fly the day to its
    end; then the result (``devices_lost`` naming only mwir), exit 1 and one error line."""
    status = tmp_path / "status.json"
    argv = ["demo", "--headless", "--stops", "60", "--speed", "2", "--json"]
    proc = _snrmon([*argv, "--status-file", str(status), "--report", "r.png"], tmp_path)
    try:
        _until_shown(proc, status, "mwir", 300)
        _camera_process(psutil.Process(proc.pid), "mwir").kill()
        out, err = proc.communicate(timeout=1500)  # a guard: a loaded machine flies slowly
    finally:
        proc.kill()
        proc.wait(10)
    err = err.decode(errors="replace")
    assert proc.returncode == 1, err
    assert re.search(LOST.format(cmd="snrmon demo", device="mwir"), err), err
    errors = _errors(err)
    assert len(errors) == 1 and errors[0].startswith("snrmon demo: error: mwir lost at "), err
    result = json.loads(out)
    assert [x["device"] for x in result["devices_lost"]] == ["mwir"], result["devices_lost"]
    assert result["devices_lost"][0]["back_utc"] is None
    lwir = [row for row in result["stops"] if row["camera"] == "lwir"]
    assert lwir and lwir[0]["n_frames"] >= 100  # the day flew on to the stop without mwir
