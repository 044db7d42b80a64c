"""Device health in a real window (Xvfb): the console on a simulated field kit whose devices
are processes of their own (a shared-memory camera, an LDM rangefinder and an NMEA GPS on
pseudo-terminals), each killed in turn as a device dies (SIGKILL). The camera's header, as its
widgets hold it and as it is painted: red, saying what is lost and for how long, and never
showing a lost device's last value as live. One console for the module."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from snrmon.gui import theme as th
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.gui.device_process import RANGE_M
from tests.gui.screen_grab import ScreenGrabber, colours_in
from tests.gui.test_real_window import click, console_process, poll, screen_point
from tests.helpers import SPOT_X, SPOT_Y, H, SpotOnNoise, W, field_config, sensor_toml

pytestmark = pytest.mark.desktop
REPO = Path(__file__).resolve().parents[2]
LIVE = f"LRF {RANGE_M:.1f}"


def device(kind: str, link: Path) -> subprocess.Popen:
    """A simulated serial device process serving ``link`` (:mod:`tests.gui.device_process`),
    once it says it is ready."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.gui.device_process", kind, str(link)],
        env={**os.environ, "PYTHONPATH": str(REPO)},
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready", kind
    return proc


def killed(proc: subprocess.Popen) -> None:
    """SIGKILL, as a device dies: nothing said, its pty closed by the kernel."""
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)


class Kit:
    def __init__(self, display: str, status: Path, console, camera, lrf, gps, screen) -> None:
        self.display = display
        self.status, self.console, self.camera, self.lrf, self.gps = (
            status,
            console,
            camera,
            lrf,
            gps,
        )
        self.screen = screen

    def poll(self, predicate, what: str, timeout_s: float = 30) -> dict:
        return poll(self.status, predicate, timeout_s, what, self.console)


@pytest.fixture(scope="module")
def kit(xvfb_screens, module_tmp):
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool not installed (apt-get install xdotool; .ci/run does)")
    display = xvfb_screens("1366x768")
    folder = module_tmp("real-health")
    ring = f"snrmon-health-{os.getpid()}"
    camera = ShmProducer(ring, W, H, SpotOnNoise(5), fps=30.0, slots=16)
    camera.start()
    lrf = device("ldm", folder / "lrf")
    gps = device("nmea", folder / "gps")
    sensor = sensor_toml(folder / "sensor.toml", fps=30.0)
    lines = f'sensor = "{sensor}"\nwidth_px = {W}\nheight_px = {H}'
    config = field_config(
        folder / "session.toml", ring, str(folder / "gps"), str(folder / "lrf"), lines
    )
    console, status = console_process(config, display, folder, theme="dark")
    screen = ScreenGrabber(display, folder)
    try:
        yield Kit(display, status, console, camera, lrf, gps, screen)
    finally:
        screen.close()
        console.send_signal(signal.SIGTERM)
        try:
            _, err = console.communicate(timeout=60)
        finally:
            console.kill()
            camera.close()
            for proc in (lrf, gps):
                proc.kill()
                proc.wait(30)
    # the console closes cleanly, then says what it lost and exits 1 (as `snrmon record` does)
    assert console.returncode == 1, err
    assert re.search(
        r"^snrmon gui: error: lrf lost at .*; gps lost at .*; cam lost at ", err, re.M
    ), err


def header(st: dict) -> str:
    return st["cameras"]["cam"]["header"]


def painted_red(kit: Kit, st: dict) -> None:
    """The state tile's value painted white on the alarm's red, and the header's frame red."""
    cam = st["cameras"]["cam"]
    image = kit.screen.grab()
    value = colours_in(image, cam["state_rect"])
    assert max(value, key=value.get) == th.ALARM, sorted(value.items(), key=lambda kv: -kv[1])[:5]
    assert "#ffffff" in value
    x, y, w, h = cam["header_rect"]
    frame = colours_in(image, [x, y + h // 2, 2, 1]) | colours_in(
        image, [x + w - 2, y + h // 2, 2, 1]
    )
    assert set(frame) == {th.ALARM}, frame


def test_a_killed_rangefinder_turns_the_header_red_for_as_long_as_it_is_lost(kit):
    st = kit.poll(
        lambda s: s["window"]["visible"] and s["cameras"]["cam"]["frames_shown"] > 10,
        "the window showing frames",
        120,
    )
    click(kit.display, *screen_point(st["cameras"]["cam"], round(SPOT_X), round(SPOT_Y)))
    st = kit.poll(
        lambda s: f"range (LRF) {RANGE_M:.1f} m" in header(s) and "GPS --" not in header(s),
        "the drone measured at the rangefinder's range, the GPS's beside it",
    )
    assert not st["cameras"]["cam"]["header_alarm"] and "LOST" not in header(st)
    killed(kit.lrf)
    lost = kit.poll(lambda s: "LRF lost" in header(s), "the header saying the LRF is lost")
    cam = lost["cameras"]["cam"]
    assert cam["header_alarm"] and "LRF LOST" in header(lost), header(lost)
    assert LIVE not in header(lost)  # its last value is not shown as if it were live
    painted_red(kit, lost)
    # the frames' range: the rangefinder's last reading while it is fresh (lrf_fresh_s, 2 s),
    # then the GPS's, the rangefinder still said lost
    gps = kit.poll(lambda s: "range (GPS)" in header(s), "the frames' range from the GPS")
    assert "LRF lost" in header(gps) and LIVE not in header(gps), header(gps)
    # and for how long: the seconds since its last reading, growing
    first = int(re.search(r"LRF lost (\d+) s", header(lost))[1])
    later = kit.poll(
        lambda s: int(re.search(r"LRF lost (\d+) s", header(s))[1]) >= first + 2,
        "the LRF's loss growing older",
    )
    assert any(
        d["kind"] == "LRF" and d["for_s"] >= first + 2 for d in later["cameras"]["cam"]["lost"]
    )


def test_a_killed_gps_then_camera_join_the_losses(kit):
    kit.poll(lambda s: "LRF lost" in header(s), "the LRF lost (the test before)")
    killed(kit.gps)
    both = kit.poll(lambda s: "GPS lost" in header(s), "the header saying the GPS is lost")
    assert re.search(r"GPS lost \d+ s", header(both)), header(both)
    assert "LRF + GPS LOST" in header(both) or "GPS + LRF LOST" in header(both), header(both)
    painted_red(kit, both)
    kit.camera.kill()  # the camera process dies: its ring is left behind, no frame comes
    dead = kit.poll(
        lambda s: "camera" in header(s).split(" | ")[0], "the header saying the camera is lost"
    )
    state = header(dead).split(" | ")[0]
    assert "camera + " in state and " LOST" in state, state
    assert "tracking" not in state and "idle" not in state, state
    painted_red(kit, dead)
    # a camera that stopped is not shown at its old frame rate, nor its last numbers as live
    still = kit.poll(lambda s: header(s).startswith("CAM  0.0 fps"), "the camera's rate at 0")
    tiles = header(still).split(" | ")
    assert "camera + " in tiles[0], tiles[0]
    (snr,) = [t for t in tiles if t.startswith("SNR(100)")]
    assert re.search(r"last frame \d+ s ago$", snr), snr
    (ratio,) = [t for t in tiles if t.startswith("measured / expected")]
    assert re.search(r", last frame \d+ s ago$", ratio), ratio
    assert still["cameras"]["cam"]["verdicts"]["ratio"] == "", still["cameras"]["cam"]["verdicts"]
    assert any(a.startswith("cam: ") for a in dead["alarms"]), dead["alarms"]
