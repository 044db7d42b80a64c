"""The camera view's help for the click in a real window (Xvfb at 1366 x 768, a field laptop):
a full 1280 x 720 MWIR frame drawn about 250 px wide, the drone a bright spot two pixels from
where its GPS position projects (an NMEA GPS on a pseudo-terminal, the camera's pointing set on
the fix). The GPS cue is a ring beside the drone, not a cross over it; the measured box is
marked at least 8 screen pixels wide; the palettes (key G) colour the sky; the status bar reads
the pixel under the pointer; a click on empty sky sets the ROI there and says it found no
object. The mouse and keys are X events (xdotool); what is read is the widgets' (the status
file) and the painted screen. One console for the module.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess

import pymap3d
import pytest

from snrmon.acquisition.geo.projection import CameraIntrinsics, Pointing, Site, project_to_pixel
from snrmon.gui.camera_view import GPS_COLOR, MIN_BOX_SCREEN_PX
from snrmon.model.presets import load_sensor
from snrmon.sim.devices.nmea_sim import NmeaSimulator
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.gui.device_process import FIX
from tests.gui.screen_grab import ScreenGrabber
from tests.gui.test_real_window import click, console_process, poll, screen_point
from tests.gui.test_real_window_layout import press
from tests.helpers import SpotOnSky

pytestmark = pytest.mark.desktop
SITE = Site(32.38, -106.48, 1200.0)
W, H = 1280, 720  # the MWIR preset's frame
BOX_YELLOW = "#ffd34d"
GPS_OFF_PX = (2, -1)  # the drone from where its GPS fix projects (a GPS's error)


def pointing_at_fix() -> tuple[Pointing, tuple[float, float]]:
    """The camera's pointing on the GPS fix, and where the fix then projects (x, y)."""
    az, el, _ = pymap3d.geodetic2aer(*FIX, SITE.lat_deg, SITE.lon_deg, SITE.alt_m)
    pointing = Pointing(float(az), float(el))
    intrinsics = CameraIntrinsics.from_sensor(load_sensor("mwir"))
    p = project_to_pixel(SITE, pointing, intrinsics, *FIX)
    assert p.in_view
    return pointing, (p.x, p.y)


class Console:
    def __init__(self, display, status, proc, screen, drone) -> None:
        self.display, self.status, self.proc, self.screen = display, status, proc, screen
        self.drone = drone  # (column, row) of the drone's peak

    def poll(self, predicate, what: str, timeout_s: float = 30) -> dict:
        return poll(self.status, predicate, timeout_s, what, self.proc)


@pytest.fixture(scope="module")
def console(xvfb_screens, module_tmp):
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool not installed (apt-get install xdotool; .ci/run does)")
    display = xvfb_screens("1366x768")
    folder = module_tmp("real-camera-view")
    pointing, (gx, gy) = pointing_at_fix()
    drone = (round(gx) + GPS_OFF_PX[0], round(gy) + GPS_OFF_PX[1])
    ring = f"snrmon-view-{os.getpid()}"
    camera = ShmProducer(ring, W, H, SpotOnSky(W, H, *drone, seed=9), fps=10.0, slots=8)
    camera.start()
    gps = NmeaSimulator(lambda t: FIX, rate_hz=10.0).start()
    config = folder / "session.toml"
    config.write_text(
        f"[site]\nlat_deg = {SITE.lat_deg}\nlon_deg = {SITE.lon_deg}\nalt_m = {SITE.alt_m}\n\n"
        f'[cameras.mwir]\nsource = "shm"\naddress = "{ring}"\nsensor = "mwir"\n'
        f"pointing_deg = [{pointing.az_deg!r}, {pointing.el_deg!r}, 0.0]\n\n"
        f'[gps]\nprotocol = "nmea"\nport = "{gps.path}"\nbaud = 38400\n'
    )
    proc, status = console_process(config, display, folder, theme="dark")
    screen = ScreenGrabber(display, folder)
    try:
        c = Console(display, status, proc, screen, drone)
        c.poll(
            lambda s: (
                s["window"]["visible"]
                and s["cameras"]["mwir"]["frames_shown"] > 3
                and s["cameras"]["mwir"]["gps_marker"]["visible"]
            ),
            "the window showing frames and the GPS cue",
            120,
        )
        yield c
    finally:
        screen.close()
        proc.send_signal(signal.SIGTERM)
        try:
            _, err = proc.communicate(timeout=60)
        finally:
            proc.kill()
            camera.close()
            gps.stop()
    assert proc.returncode == 0, err


def cam(st: dict) -> dict:
    return st["cameras"]["mwir"]


def pixels_of(image, colour: str, centre: list[int], half: int) -> list[tuple[int, int]]:
    """The screen pixels of ``colour`` within ``half`` px of ``centre`` in a grab."""
    cx, cy = centre
    return [
        (x, y)
        for y in range(cy - half, cy + half + 1)
        for x in range(cx - half, cx + half + 1)
        if image.pixelColor(x, y).name() == colour
    ]


@pytest.mark.slow
def test_the_frame_is_drawn_small_and_the_gps_cue_is_a_ring_beside_the_drone(console, artifacts):
    st = console.poll(lambda s: cam(s)["gps_xy"] is not None, "the fix projected")
    c = cam(st)
    (x0, _), (x1, _) = c["screen_first_pixel"], c["screen_last_pixel"]
    assert x1 - x0 < 400  # the case: the 1280-px frame a few hundred px wide
    assert c["box_screen_px"] < MIN_BOX_SCREEN_PX
    ring = c["gps_marker"]
    assert ring["visible"] and ring["symbol"] == "o" and ring["hollow"] and ring["size_px"] >= 24
    gx, gy = c["gps_xy"]
    at = screen_point(c, round(gx), round(gy))
    assert max(abs(ring["at"][0] - at[0]), abs(ring["at"][1] - at[1])) <= 1, (ring, at)
    drone = screen_point(c, *console.drone)
    image = console.screen.grab()
    image.save(str(artifacts / "real-window-camera-view-1366x768.png"))  # for a person to see
    cyan = pixels_of(image, GPS_COLOR, ring["at"], int(ring["size_px"]))
    assert cyan, "no ring painted"
    xs, ys = [p[0] for p in cyan], [p[1] for p in cyan]
    assert max(xs) - min(xs) >= 24 and max(ys) - min(ys) >= 24, (min(xs), max(xs))
    # the drone shows: nothing of the ring within 8 px of it (a cross over it would be)
    near = [p for p in cyan if max(abs(p[0] - drone[0]), abs(p[1] - drone[1])) <= 8]
    assert not near, near
    # and it is the brightest thing there (grey palette: sky dark, the drone light)
    assert image.pixelColor(*drone).lightness() > 128, image.pixelColor(*drone).name()


def test_a_click_on_sky_sets_the_roi_there_and_says_it_found_no_object(console):
    st = console.poll(lambda s: True, "a status")
    x, y = 200, 600  # far from the drone
    click(console.display, *screen_point(cam(st), x, y))
    said = console.poll(
        lambda s: (
            any(m.startswith("mwir: ROI set at column ") for m in s["messages"])
            and any(m.startswith("mwir: no object at the click") for m in s["messages"])
        ),
        "the console saying the click found no object",
    )
    (where,) = [m for m in said["messages"] if m.startswith("mwir: ROI set at column ")][-1:]
    col, row = (
        int(v) for v in re.match(r"mwir: ROI set at column (\d+), row (\d+)", where).groups()
    )
    # a screen pixel covers about five image pixels here
    assert abs(col - x) <= 5 and abs(row - y) <= 5, where
    assert f"mwir: no object at the click (column {col}, row {row})" in " ".join(said["messages"])


def test_the_drone_s_box_is_marked_at_least_8_screen_px_wide(console):
    st = console.poll(lambda s: True, "a status")
    click(console.display, *screen_point(cam(st), *console.drone))
    dx, dy = console.drone
    on = console.poll(
        lambda s: cam(s)["peak"] == [dx, dy] and cam(s)["box_marker"]["visible"],
        "the box on the drone",
    )
    marker = cam(on)["box_marker"]
    assert marker["size_px"] >= MIN_BOX_SCREEN_PX and marker["hollow"]
    assert (
        marker["at"] == screen_point(cam(on), dx, dy)
        or max(abs(a - b) for a, b in zip(marker["at"], screen_point(cam(on), dx, dy), strict=True))
        <= 1
    )
    yellow = pixels_of(console.screen.grab(), BOX_YELLOW, marker["at"], 12)
    assert yellow, "no box painted"
    xs, ys = [p[0] for p in yellow], [p[1] for p in yellow]
    assert max(xs) - min(xs) + 1 >= MIN_BOX_SCREEN_PX and max(ys) - min(ys) + 1 >= MIN_BOX_SCREEN_PX


def image_point(c: dict, sx: int, sy: int) -> tuple[float, float]:
    """The image position (column, row, pixel centres on integers) under screen point
    (sx, sy), from where the console says its first and last pixels are."""
    (x0, y0), (x1, y1) = c["screen_first_pixel"], c["screen_last_pixel"]
    rows, cols = c["shape"]
    return (sx - x0) * (cols - 1) / (x1 - x0), (sy - y0) * (rows - 1) / (y1 - y0)


def test_the_status_bar_reads_the_pixel_under_the_pointer(console):
    st = console.poll(lambda s: True, "a status")
    c = cam(st)
    sx, sy = screen_point(c, 900, 150)
    (x0, _), (x1, _) = c["screen_first_pixel"], c["screen_last_pixel"]
    per_px = (c["shape"][1] - 1) / (x1 - x0)  # image pixels per screen pixel (about 4 here)
    env = {**os.environ, "DISPLAY": console.display}
    readout = re.compile(r"mwir column (\d+), row (\d+): (\d+) DN$")
    for dx in (0, 3):  # two places: the readout follows the pointer
        subprocess.run(
            ["xdotool", "mousemove", "--sync", str(sx + dx), str(sy)], env=env, check=True
        )
        x, y = image_point(c, sx + dx, sy)
        read = console.poll(
            lambda s, x=x: (m := readout.match(s["pointer"])) and abs(int(m[1]) - x) <= per_px,
            f"the pointer's readout {dx} px on",
        )
        _, row, dn = (int(v) for v in readout.match(read["pointer"]).groups())
        assert abs(row - y) <= per_px, (read["pointer"], x, y)
        assert 1000 - 8 * 6 <= dn <= 1000 + 8 * 6, read["pointer"]  # sky: 1000 DN, noise 6 DN


def sky_patch(console: Console, st: dict) -> list:
    """The colours of a 12 x 12 screen-px patch of sky (image around column 300, row 500)."""
    image = console.screen.grab()
    x, y = screen_point(cam(st), 300, 500)
    return [image.pixelColor(x + i, y + j) for i in range(12) for j in range(12)]


@pytest.mark.parametrize("palette", ["white-hot", "black-hot", "ironbow", "grey"])
def test_g_changes_the_palette_of_the_sky_painted(console, palette):
    before = console.poll(lambda s: True, "a status")
    sky_before = sky_patch(console, before)
    press(console.display, "g")
    st = console.poll(lambda s: cam(s)["palette"] == palette, f"the palette {palette}")
    assert f"palette: {palette}" in st["messages"]
    # the image painted in it (a frame shown after the change: the palette is the view's)
    st = console.poll(
        lambda s: cam(s)["frames_shown"] > cam(st)["frames_shown"], "a frame in the palette"
    )
    sky = sky_patch(console, st)
    grey = all(c.red() == c.green() == c.blue() for c in sky)
    mean = sum(c.lightness() for c in sky) / len(sky)
    mean_before = sum(c.lightness() for c in sky_before) / len(sky_before)
    if palette == "ironbow":
        assert not grey  # colours: the sky's low levels purple-black
    else:
        assert grey, [c.name() for c in sky[:5]]
    if palette == "black-hot":  # white-hot's greys turned over: v -> 255 - v
        assert abs(mean - (255 - mean_before)) < 12, (mean_before, mean)
    if palette == "white-hot":  # as grey
        assert abs(mean - mean_before) < 20, (mean_before, mean)
