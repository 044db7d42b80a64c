"""What became of the operator's click, told once (docs/tracking.md, "Per frame", 1).

The click takes the object nearest it; when there is none the track is ``lost`` (reason
``no_object``) on the click's first frame and searches outward from the click, so it may settle
on an object far from where the operator clicked. Both happen within a few frames, faster than a
display refreshes its status, so :class:`ClickNews` latches them as messages for the console:

- ``no object at the click (column X, row Y): the track searches around it``;
- then, once the track holds an object again, ``the track found an object at column X, row Y,
  N px from the click``.

A click on an object says nothing more (the ROI message is the console's own).
"""

from __future__ import annotations

import math
import threading

from snrmon.acquisition.engine.inputs import FrameOutput, SetRoi
from snrmon.acquisition.measure.peak_snr import FLAG_LOST
from snrmon.acquisition.track.config import TrackState

HOLDING = (TrackState.TRACKING, TrackState.GPS_CUED)


class ClickNews:
    """Fed every measured frame (:meth:`frame`, on the measurement thread); :meth:`take` hands the
    messages to the display thread once each."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._searching: tuple[int, int] | None = None  # a click with no object, not found yet
        self._news: list[str] = []

    def frame(self, out: FrameOutput) -> None:
        """What the engine made of a frame (its commands applied before it, its measurement)."""
        m = out.measurement
        clicks = [c for c in out.applied if isinstance(c, SetRoi)]
        with self._lock:
            if clicks:
                self._searching = None
                if m is not None and m.track_reason == "no_object":
                    x, y = clicks[-1].x, clicks[-1].y
                    self._searching = (x, y)
                    self._news.append(
                        f"no object at the click (column {x}, row {y}): "
                        "the track searches around it"
                    )
                return
            if m is None or self._searching is None:
                return
            if m.track_state in HOLDING and FLAG_LOST not in m.result.flags:
                x, y = self._searching
                r = m.result
                far = math.hypot(r.peak_x - x, r.peak_y - y)
                self._news.append(
                    f"the track found an object at column {r.peak_x}, row {r.peak_y}, "
                    f"{far:.0f} px from the click"
                )
                self._searching = None

    def take(self) -> list[str]:
        with self._lock:
            news, self._news = self._news, []
        return news
