"""The console as a person sees it on a real screen: ``snrmon gui --replay`` on a real X server
(Xvfb at 1366 x 768, a field laptop, and 1920 x 1080), keys pressed with xdotool (X events, not
Qt calls), and what the window then shows read back from its status file: its geometry (it
fills the screen at a first start), the legibility figures measured from its widgets
(:func:`snrmon.gui.legibility.layout_report`), and each camera header's words against the
session's own numbers in the same snapshot. The window's last picture is kept in
``artifacts/`` for a person to look at.

The session: the paper's seven stops flown out and back by both cameras
(:func:`snrmon.examples.example_session`, recorded with the real recorder), replayed at 1000 x.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from PySide6.QtGui import QImage

from snrmon.examples import example_session
from tests.gui.test_real_window import poll

pytestmark = pytest.mark.desktop
REPO = Path(__file__).resolve().parents[2]
STOPS_M = (37.0, 126.0, 199.0, 336.0, 393.0, 451.0, 508.0)


@pytest.fixture(scope="module")
def flight(module_tmp) -> Path:
    path = module_tmp("real-layout") / "flight.h5"
    example_session(path, ranges_m=STOPS_M, hover_s=4.0, transit_s=1.0, fps=10.0)
    return path


def press(display: str, keys: str) -> None:
    """``keys`` (xdotool's names) into the console's window, focused first (no window
    manager gives it the focus on a bare X server)."""
    env = {**os.environ, "DISPLAY": display}
    subprocess.run(
        ["xdotool", "search", "--name", "^snrmon console$", "windowfocus", "--sync", "key", keys],
        env=env,
        check=True,
        timeout=30,
    )


def settled(s: dict) -> bool:
    """The replay at its end, the window laid out and its newest words placed."""
    r = s.get("replay")
    lay = s["layout"]
    return (
        s["window"]["visible"]
        and r is not None
        and r["index"] == r["length"] - 1
        and s["view"]["layout_fitted"]
        and len(s["stops"]) == 2 * len(STOPS_M)
        and not lay["cut_texts"]
        and not lay["overlaps"]
    )


@pytest.mark.parametrize(
    ("size", "theme", "all_rows"),
    [("1366x768", "dark", False), ("1920x1080", "daylight", True)],
)
@pytest.mark.slow
def test_the_console_on_a_real_screen_is_legible(
    xvfb_screens, flight, tmp_path, artifacts, size, theme, all_rows
):
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool not installed (apt-get install xdotool; .ci/run does)")
    display = xvfb_screens(size)
    width, height = (int(v) for v in size.split("x"))
    status, png = tmp_path / "status.json", tmp_path / "console.png"
    env = {
        **os.environ,
        "DISPLAY": display,
        "QT_QPA_PLATFORM": "xcb",
        "XDG_CONFIG_HOME": str(tmp_path / "config"),  # a first start: nothing saved
        "PYTHONPATH": str(REPO),
    }
    cmd = [sys.executable, "-m", "snrmon", "gui", "--replay", str(flight), "--speed", "1000"]
    cmd += ["--status-file", str(status), "--screenshot", str(png), "--theme", theme]
    cmd += ["--duration", "300"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        st = poll(status, settled, 120, f"the replayed console laid out at {size}", proc)
        # it fills the screen it opened on
        w = st["window"]
        assert (w["x"], w["y"], w["width"], w["height"]) == (0, 0, width, height)
        lay = st["layout"]
        assert lay["images_shown"]
        for name, chart in (lay["range_plots"] | lay["strip_charts"]).items():
            assert not chart["legend_over_data"] and chart["axis_titles_fit"], name
        (plot,) = lay["range_plots"].values()
        assert plot["area_fraction"] >= 1 / 3, plot
        stops = lay["stops"]
        assert stops["rows"] == 14 and stops["in_view"] >= 4
        if all_rows:
            assert stops["in_view"] == 14 and stops["columns_fit"], stops

        # each header says the session's numbers, from the same snapshot
        for name, cam in st["cameras"].items():
            a, p = cam["agreement"], cam["stop"]
            header = cam["header"]
            assert f"SNR(100) ± error {cam['snr_mean']:.2f} ± {cam['snr_sem']:.2f}" in header
            assert f"range ({cam['range_source'].upper()}) {cam['range_m']:.1f} m" in header
            assert f"LRF {st['lrf_range_m']:.1f}, GPS {st['gps_range_m']:.1f}" in header
            assert f"expected Eq. (4) {a['expected']:.1f}" in header
            assert f"measured / expected {a['ratio']:.2f} {a['verdict']}:" in header
            assert f"{p['n_frames']} / {p['n_wanted']}" in header
            assert header.startswith(f"{name.upper()}  ")
            assert cam["track_state"] in header

        # P: the SNR-versus-range plot in the images' place; C: the other camera; Ctrl+D: the
        # other theme. The keys reach the window as a person's would.
        first = st["view"]["active_camera"]
        press(display, "p")
        big = poll(status, lambda s: s["view"]["range_large"] and settled(s), 30, "P", proc)
        (plot,) = big["layout"]["range_plots"].values()
        assert not big["layout"]["images_shown"] and plot["area_fraction"] > 0.5
        press(display, "p")
        poll(status, lambda s: not s["view"]["range_large"] and settled(s), 30, "P again", proc)
        # S: the stop table in the images' place, every stop of both cameras in view
        press(display, "s")
        table = poll(status, lambda s: s["view"]["stops_large"] and settled(s), 30, "S", proc)
        assert table["layout"]["stops"]["in_view"] == 14, table["layout"]["stops"]
        press(display, "s")
        poll(status, lambda s: not s["view"]["stops_large"] and settled(s), 30, "S again", proc)
        press(display, "c")
        poll(status, lambda s: s["view"]["active_camera"] != first, 30, "C", proc)
        press(display, "ctrl+d")
        other = "dark" if theme == "daylight" else "daylight"
        poll(status, lambda s: s["view"]["theme"] == other, 30, "Ctrl+D", proc)
        press(display, "ctrl+d")
        poll(status, lambda s: s["view"]["theme"] == theme and settled(s), 30, "Ctrl+D", proc)
    finally:
        proc.send_signal(signal.SIGTERM)  # the console saves its screenshot and closes
        try:
            _, err = proc.communicate(timeout=60)
        finally:
            proc.kill()
    assert proc.returncode == 0, err
    image = QImage(str(png))
    assert (image.width(), image.height()) == (width, height)
    shutil.copy(png, artifacts / f"real-window-{size}-{theme}.png")
