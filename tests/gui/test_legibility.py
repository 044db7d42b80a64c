"""The console as an operator reads it on a field laptop (1366 x 768) and a desktop screen
(1920 x 1080): every panel legible, measured from the widgets' geometry
(:func:`snrmon.gui.legibility.layout_report`), the header's numbers read back against the
session's own status, and the operator's keys.

A seven-stop flight (the paper's ranges, both cameras) recorded with the real recorder
(:func:`snrmon.examples.example_session`) is replayed to its end once; each test opens a new
window on it as at a first start (fresh settings), at the screen's size. Screenshots go to
``artifacts/`` (see tests/conftest.py) for a person to look at.
"""

from __future__ import annotations

import contextlib

import pytest
from PySide6.QtCore import QSettings, Qt
from PySide6.QtTest import QTest

from snrmon.acquisition.prediction import ModelPredictor
from snrmon.acquisition.replay.player import ReplayPlayer
from snrmon.acquisition.track.config import TrackState
from snrmon.examples import example_session
from snrmon.gui.app import console_application
from snrmon.gui.legibility import layout_report
from snrmon.gui.main_window import ConsoleWindow

STOPS_M = (37.0, 126.0, 199.0, 336.0, 393.0, 451.0, 508.0)  # the paper's (section 4)


@pytest.fixture(scope="module")
def flight(module_tmp):
    """The recording, replayed to its end through the model (a ReplayPlayer: the session)."""
    path = module_tmp("legible") / "flight.h5"
    example_session(path, ranges_m=STOPS_M, hover_s=4.0, transit_s=1.0, fps=10.0)
    player = ReplayPlayer(path, speed=1000.0)
    cfg = player.config
    player.set_predictor(ModelPredictor({c.name: c.sensor for c in cfg.cameras}, cfg.target))
    with player:
        player.play()
        assert player.wait_end(120.0), f"the replay did not end: {player.position()}"
        yield player


def open_console(qtbot, player, tmp_path, size: tuple[int, int], theme: str) -> ConsoleWindow:
    console_application(headless=True)
    settings = QSettings(str(tmp_path / "console.ini"), QSettings.Format.IniFormat)
    win = ConsoleWindow(player, settings=settings, theme=theme)
    qtbot.addWidget(win)
    win.set_size(*size)
    win.show()
    qtbot.waitUntil(lambda: win.layout_fitted, timeout=10_000)
    win.refresh_status()
    win.refresh_stops()
    qtbot.waitUntil(lambda: len(win.stop_table.cells()) == 2 * len(STOPS_M), timeout=10_000)
    settle(qtbot, win)
    return win


def settle(qtbot, win: ConsoleWindow) -> dict:
    """The layout once Qt has placed the newest words (a label laid out again after its text
    changed): what a person sees, not the instant between setText and the next layout pass."""
    reports = []

    def placed() -> bool:
        reports.append(layout_report(win))
        return not reports[-1]["cut_texts"] and not reports[-1]["overlaps"]

    with contextlib.suppress(AssertionError):  # the caller's assertions say what stayed cut
        qtbot.waitUntil(placed, timeout=5000)
    return reports[-1]


def check_legible(rep: dict, *, all_rows: bool) -> None:
    assert rep["cut_texts"] == [], rep["cut_texts"]
    assert rep["overlaps"] == [], rep["overlaps"]
    for name, chart in (rep["range_plots"] | rep["strip_charts"]).items():
        assert not chart["legend_over_data"], name
        assert chart["axis_titles_fit"], name
    (plot,) = rep["range_plots"].values()  # the active camera's
    assert plot["area_fraction"] >= 1 / 3, plot
    stops = rep["stops"]
    assert stops["rows"] == 2 * len(STOPS_M)
    if all_rows:
        assert stops["in_view"] == stops["rows"] and stops["columns_fit"], stops


def check_header_reads_the_status(win: ConsoleWindow) -> None:
    """Each number on a header's tiles is the status snapshot's, as the operator reads it."""
    st = win.last_status
    for name, panel in win.panels.items():
        cs = st.cameras[name]
        m, a, p = cs.last, cs.agreement, cs.stop
        tiles = panel.header.tiles
        mean, sem = tiles["snr"].value.text().split(" ± ")
        assert float(mean) == round(m.snr_mean, 2) and float(sem) == round(cs.snr_sem, 2)
        assert tiles["range"].value.text() == f"{m.range_m:.1f} m"
        assert tiles["range"].caption.text() == f"range ({m.range_source.upper()})"
        assert float(tiles["expected"].value.text()) == round(a.expected, 1)
        assert float(tiles["ratio"].value.text()) == round(m.snr_mean / a.expected, 2)
        assert tiles["ratio"].verdict == a.verdict and a.verdict in ("inside", "near", "outside")
        assert tiles["stop"].value.text() == f"{p.n_frames} / {p.n_wanted}"
        assert tiles["stop"].caption.text().startswith(f"stop {p.stop}")
        assert tiles["state"].value.text() == cs.track_state.value
        assert tiles["state"].caption.text().startswith(name.upper())


@pytest.mark.parametrize(
    ("size", "theme", "all_rows"),
    [((1366, 768), "dark", False), ((1920, 1080), "daylight", True)],
    ids=["1366x768", "1920x1080"],
)
def test_every_panel_is_legible_at_the_screen_size(
    qtbot, flight, tmp_path, artifacts, size, theme, all_rows
):
    """No text cut, no legend over data, no part over another, the range plot at least a
    third of the window; at 1920 x 1080 every stop of both cameras in view with every
    column the table keeps at that width, at 1366 x 768 with S (the table large)."""
    win = open_console(qtbot, flight, tmp_path, size, theme)
    assert (win.width(), win.height()) == size
    rep = settle(qtbot, win)
    check_legible(rep, all_rows=all_rows)
    check_header_reads_the_status(win)
    win.save_screenshot(artifacts / f"console-{size[0]}x{size[1]}-{theme}.png")
    # P: the range plot takes the images' place, legible too
    QTest.keyClick(win, Qt.Key.Key_P)
    large = settle(qtbot, win)
    assert win.range_large and not large["images_shown"]
    (plot,) = large["range_plots"].values()
    assert plot["area_fraction"] > 0.5 and not plot["legend_over_data"]  # over half the window
    assert large["cut_texts"] == [] and large["overlaps"] == []
    win.save_screenshot(artifacts / f"console-{size[0]}x{size[1]}-{theme}-range-large.png")
    QTest.keyClick(win, Qt.Key.Key_P)
    assert not win.range_large and layout_report(win)["images_shown"]
    # S: the stop table takes the images' place: every stop of both cameras in view, on the
    # laptop's screen too; again, and the table is back under the images, in front of its tabs
    QTest.keyClick(win, Qt.Key.Key_S)
    table = settle(qtbot, win)
    assert win.large == "stops" and not table["images_shown"]
    assert table["stops"]["rows"] == 14 and table["stops"]["in_view"] == 14, table["stops"]
    assert table["cut_texts"] == [] and table["overlaps"] == []
    win.save_screenshot(artifacts / f"console-{size[0]}x{size[1]}-{theme}-stops-large.png")
    QTest.keyClick(win, Qt.Key.Key_S)
    back = settle(qtbot, win)
    assert win.large is None and back["images_shown"] and back["stops"]["visible"]


def test_operator_keys_switch_camera_release_and_reselect_the_track(qtbot, flight, tmp_path):
    win = open_console(qtbot, flight, tmp_path, (1920, 1080), "dark")
    names = list(win.panels)
    first = win.active_camera
    QTest.keyClick(win, Qt.Key.Key_C)
    second = win.active_camera
    assert second != first and second in names
    assert win.range_tabs.currentWidget() is win.range_plots[second]  # the plot follows
    assert win.panels[second].header.active and not win.panels[first].header.active

    peak = win.last_status.cameras[second].last.result
    QTest.keyClick(win, Qt.Key.Key_Escape)  # release: the shown frame is not measured
    flight.wait_idle(10.0)
    win.refresh_status()
    assert win.last_status.cameras[second].track_state is TrackState.IDLE
    assert f"{second}: track released" in win.messages

    QTest.keyClick(win, Qt.Key.Key_T)  # re-select: no GPS projection here, the last peak
    flight.wait_idle(10.0)
    win.refresh_status()
    cs = win.last_status.cameras[second]
    assert cs.track_state is not TrackState.IDLE and cs.roi_xy is not None
    where = f"(column {peak.peak_x}, row {peak.peak_y})"
    assert f"{second}: track re-selected at the last peak {where}" in win.messages

    QTest.keyClick(win, Qt.Key.Key_E)  # mark an event: refused in a replay, and said so
    assert win.messages[-1] == "note not added: not available in replay"


@pytest.mark.slow
def test_daylight_theme_and_font_scale_keys_restyle_and_are_remembered(qtbot, flight, tmp_path):
    win = open_console(qtbot, flight, tmp_path, (1920, 1080), "dark")
    plot = win.range_plots[win.active_camera].plot
    QTest.keyClick(win, Qt.Key.Key_D, Qt.KeyboardModifier.ControlModifier)
    assert win.theme_name == "daylight"
    assert plot.backgroundBrush().color().name() == "#ffffff"  # white plots, black text
    qtbot.waitUntil(lambda: win.palette().color(win.foregroundRole()).name() == "#000000")
    before = win.panels[win.active_camera].header.tiles["snr"].value.font().pointSizeF()
    QTest.keyClick(win, Qt.Key.Key_Equal, Qt.KeyboardModifier.ControlModifier)
    assert win.font_scale > 1.0
    after = win.panels[win.active_camera].header.tiles["snr"].value.font().pointSizeF()
    assert after == pytest.approx(before * win.font_scale)
    rep = settle(qtbot, win)
    assert rep["cut_texts"] == [] and rep["overlaps"] == []  # still legible, larger
    win.close()
    settings = QSettings(str(tmp_path / "console.ini"), QSettings.Format.IniFormat)
    again = ConsoleWindow(flight, settings=settings)
    qtbot.addWidget(again)
    assert (again.theme_name, again.font_scale) == ("daylight", win.font_scale)
    again.set_view("dark", 1.0)  # the process's theme back for the tests after this one
