"""The first start (no saved settings) on three real screens (Xvfb, 1366 x 768 to
2560 x 1440): the window fills the available screen, no text of it is under 11 px, and the
shortcut list (F1, opened with xdotool's key) scrolls with its OK button on the screen."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from snrmon.examples import example_session
from tests.gui.test_real_window import poll
from tests.gui.test_real_window_layout import press
from tests.gui.test_real_window_replay import closed, console

pytestmark = pytest.mark.desktop
MIN_TEXT_PX = 11


@pytest.fixture(scope="module")
def flight(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("first-start") / "flight.h5"
    example_session(path, ranges_m=(37.0, 126.0), hover_s=4.0, transit_s=1.0, fps=10.0)
    return path


def inside(rect: list[int], screen: list[int]) -> bool:
    x, y, w, h = rect
    sx, sy, sw, sh = screen
    return sx <= x and sy <= y and x + w <= sx + sw and y + h <= sy + sh


@pytest.mark.slow
@pytest.mark.parametrize("size", ["1366x768", "1920x1080", "2560x1440"])
def test_first_start_fills_the_screen_legibly(xvfb_screens, flight, tmp_path, size):
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool not installed (apt-get install xdotool; .ci/run does)")
    display = xvfb_screens(size)
    width, height = (int(v) for v in size.split("x"))
    proc, status = console(display, flight, tmp_path, "1000")  # XDG_CONFIG_HOME: nothing saved
    try:
        st = poll(
            status,
            lambda s: s["window"]["visible"] and s["view"]["layout_fitted"] and s["stops"],
            120,
            f"the console laid out at {size}",
            proc,
        )
        w = st["window"]
        assert st["screen"] == [0, 0, width, height]
        assert (w["x"], w["y"], w["width"], w["height"]) == (0, 0, width, height)
        sizes = st["layout"]["text_px"]
        assert {"labels", "tables", "plot ticks"} <= set(sizes), sizes
        small = {kind: px for kind, px in sizes.items() if px < MIN_TEXT_PX}
        assert not small, f"texts under {MIN_TEXT_PX} px at {size}: {small}"

        press(display, "F1")
        box = poll(status, lambda s: s["shortcuts"] is not None, 30, "the shortcut list", proc)
        shortcuts = box["shortcuts"]
        assert inside(shortcuts["rect"], st["screen"]), shortcuts
        assert inside(shortcuts["ok"], st["screen"]), shortcuts
        if size == "1366x768":  # the list is taller than this screen: it scrolls
            assert shortcuts["scroll_max"] > 0, shortcuts
    finally:
        err = closed(proc)
    assert proc.returncode == 0, err
