"""The stop table in a real window (Xvfb, 1920 x 1080): each row's measured / expected against
the expected reading of the rule that row was measured with, read from the table's cells, and
its colour as the widget holds it and as it is painted on the screen.

The recording: three stops of both cameras (:func:`snrmon.examples.example_session`, the real
recorder; 2 MB), the drone bright enough at 37 m that its light reaches the 7x7 box's rim (those
rows are measured against the rim outside its extent, the expected readings of the two rules
there 10x apart) and a point at 126 m and 199 m (the paper's rim). The LWIR rows come first in
the table, as in the replay where one table-wide rule used to divide every row by the first
camera's expected reading. One console for the module, replayed to its end at 1000 x.
"""

from __future__ import annotations

import shutil

import pytest

from snrmon.examples import example_session
from snrmon.gui import theme as th
from tests.gui.screen_grab import ScreenGrabber, colours_in
from tests.gui.test_real_window import poll
from tests.gui.test_real_window_replay import closed, console

pytestmark = pytest.mark.desktop
STOPS_M = (37.0, 126.0, 199.0)
THEME = "dark"
TAGS = {"rim": "rim", "extent": "extent"}  # the word after the ratio in its cell


@pytest.fixture(scope="module")
def table(xvfb_screens, module_tmp):
    """The console's last status once the replay has ended with every row final, and a grab
    of the screen then."""
    if shutil.which("xdotool") is None:
        pytest.skip("xdotool not installed (apt-get install xdotool; .ci/run does)")
    display = xvfb_screens("1920x1080")
    folder = module_tmp("real-stop-table")
    flight = example_session(
        folder / "flight.h5", ranges_m=STOPS_M, hover_s=4.0, transit_s=1.0, fps=10.0
    ).path
    proc, status = console(display, flight, folder, "1000", "--theme", THEME)
    grabber = ScreenGrabber(display, folder)
    try:
        st = poll(
            status,
            lambda s: (
                s["window"]["visible"]
                and s["replay"]["index"] == s["replay"]["length"] - 1
                and len(s["stops"]) == 2 * len(STOPS_M)
                and "collecting" not in " ".join(row[-1] for row in s["stops"])
                and all(r is not None for r in s["stop_table"]["ratio_rects"])
            ),
            120,
            "the replay's end with every stop's row in view",
            proc,
        )
        # the screen after the status that said so: the table is painted by then (it only
        # changes with its rows, which no longer change)
        yield (
            st,
            poll(status, lambda s: s["t_unix"] > st["t_unix"], 30, "a repaint", proc),
            (grabber.grab()),
        )
    finally:
        grabber.close()
        err = closed(proc)
    assert proc.returncode == 0, err


def number(text: str) -> float:
    return float(text.split(" ± ")[0])


def rule_of(background: str) -> str | None:
    """The rule a row's background makes applicable, written out here: any frame against the
    extent's rim, the extent rule; every frame against the 7x7 rim, the paper's; the clear-sky
    rectangle, none."""
    methods = set(background.split("+"))
    if "rect" in methods or background == "--":
        return None
    return "extent" if "extent_rim" in methods else "rim"


def verdicts(mean: float, sem: float, band: str) -> set[str]:
    """The band's verdict of a row from its cells (inside; near: within 2 errors of the mean of
    the nearer edge; outside), every one the cells' rounding allows."""
    lo, hi = (float(v) for v in band.split("–"))
    out = set()
    for m in (mean - 0.005, mean + 0.005):
        for lo_, hi_ in ((lo - 0.05, hi + 0.05), (lo + 0.05, hi - 0.05)):
            if lo_ <= m <= hi_:
                out.add("inside")
            elif min(abs(m - lo_), abs(m - hi_)) <= 2 * sem:
                out.add("near")
            else:
                out.add("outside")
    return out


@pytest.mark.slow
def test_each_row_s_ratio_is_against_its_own_rule_s_expected_reading(table):
    st, _, _ = table
    keys = st["stop_table"]["columns"]
    rules = set()
    for cells in st["stops"]:
        row = dict(zip(keys, cells, strict=True))
        where = f"{row['camera']} stop {row['stop']} ({row['lrf_range_m']} m, {row['background']})"
        rule = rule_of(row["background"])
        assert rule is not None, where
        rules.add(rule)
        mean = number(row["snr_mean"])
        own = float(row[f"model_expected_eq4_{rule}"])
        other = float(row[f"model_expected_eq4_{'rim' if rule == 'extent' else 'extent'}"])
        value, tag = row["ratio"].split()
        assert tag == TAGS[rule], where
        # the cells' rounding: the mean to 0.01, the expected reading to 0.1
        slack = mean / own * (0.005 / mean + 0.05 / own) + 0.005
        assert abs(float(value) - mean / own) <= slack, (where, row["ratio"], mean, own)
        if rule == "extent":  # the other rule's reading would have been far off
            assert abs(mean / other - mean / own) > 0.5, where
    assert rules == {"rim", "extent"}  # both rules in one table
    assert st["stops"][0][keys.index("camera")] == "lwir"  # the LWIR first, as in the issue


def test_each_row_s_colour_is_its_own_rule_s_verdict_held_and_painted(table, artifacts):
    _, st, screen = table
    screen.save(str(artifacts / "real-window-stop-table-1920x1080.png"))  # for a person to see
    keys = st["stop_table"]["columns"]
    colours = th.theme_named(THEME).verdicts
    seen = set()
    for cells, held, rect in zip(
        st["stops"], st["stop_table"]["colours"], st["stop_table"]["ratio_rects"], strict=True
    ):
        row = dict(zip(keys, cells, strict=True))
        where = f"{row['camera']} stop {row['stop']}: {row['ratio']} in {row['band']}"
        allowed = verdicts(
            number(row["snr_mean"]), number(row["snr_mean"].split(" ± ")[1]), row["band"]
        )
        by_colour = {tuple(colours[v]): v for v in allowed}
        fill, ink = held["ratio"]
        assert (fill, ink) in by_colour, (where, held, allowed)
        seen.add(by_colour[(fill, ink)])
        # painted: the cell's background is its fill (most of its pixels), its words in its ink
        painted = colours_in(screen, rect)
        assert max(painted, key=painted.get) == fill, (where, sorted(painted.items())[:8])
        assert ink in painted, (where, ink)
    assert len(seen) >= 2, seen  # the colours tell rows apart
