"""What became of a click is told once: no object at the click, then where the search found one."""

from __future__ import annotations

from types import SimpleNamespace

from snrmon.acquisition.engine.inputs import SetRoi
from snrmon.acquisition.runtime.click_news import ClickNews


def _m(state: str, reason: str = "", x: int = 0, y: int = 0, lost: bool = False):
    result = SimpleNamespace(peak_x=x, peak_y=y, flags=frozenset({"lost"} if lost else ()))
    return SimpleNamespace(track_state=state, track_reason=reason, result=result)


def _out(applied: tuple, m):
    """What the engine hands its subscribers of a frame: the commands applied, the measurement."""
    return SimpleNamespace(applied=applied, measurement=m)


def test_a_click_on_empty_sky_then_the_search_finding_the_drone_is_told_once_each():
    news = ClickNews()
    news.frame(_out((), _m("tracking", x=5, y=5)))  # the previous track: nothing to tell
    news.frame(_out((SetRoi(20, 70),), _m("lost", "no_object", 20, 70, lost=True)))
    assert news.take() == [
        "no object at the click (column 20, row 70): the track searches around it"
    ]
    news.frame(_out((), _m("reacquiring", "confirming", 60, 45, lost=True)))  # not held yet
    assert news.take() == []
    news.frame(_out((), _m("tracking", x=64, y=41)))
    news.frame(_out((), _m("tracking", x=64, y=41)))
    assert news.take() == ["the track found an object at column 64, row 41, 53 px from the click"]
    assert news.take() == []


def test_a_click_on_an_object_says_nothing_and_ends_a_search():
    news = ClickNews()
    news.frame(_out((SetRoi(20, 70),), _m("lost", "no_object", 20, 70, lost=True)))
    news.take()
    news.frame(_out((SetRoi(64, 41),), _m("tracking", x=64, y=41)))  # the operator clicks the drone
    news.frame(_out((), _m("tracking", x=64, y=41)))
    assert news.take() == []
