"""What the tracker remembers of an object from frame to frame: its history, and a candidate
being confirmed after a loss.

:class:`ObjectHistory` keeps the recent prominence and core area of the accepted object (the
medians the tracker compares a new detection with) and its core box relative to its centroid
(where to look on the next frame). :class:`Candidate` is a reacquisition candidate: its own
position, velocity and how many consecutive frames confirmed it. Both serialise to JSON-able
dicts with floats kept exactly (``Tracker.state``).
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import asdict, dataclass

from snrmon.acquisition.measure.blob import Blob, Box
from snrmon.acquisition.track.config import AppearanceConfig, TrackerConfig
from snrmon.acquisition.track.search import is_object


def box_rel(blob: Blob) -> tuple[float, float, float, float]:
    """The core box relative to the centroid."""
    x0, y0, x1, y1 = blob.core_box
    cx, cy = blob.centroid_x, blob.centroid_y
    return (x0 - cx, y0 - cy, x1 - cx, y1 - cy)


def box_at(rel: tuple[float, float, float, float], x: float, y: float, grow: int = 0) -> Box:
    """A relative box placed at centroid (x, y), grown by ``grow`` pixels each side."""
    return (
        math.floor(x + rel[0] + 0.5) - grow,
        math.floor(y + rel[1] + 0.5) - grow,
        math.floor(x + rel[2] + 0.5) + grow,
        math.floor(y + rel[3] + 0.5) + grow,
    )


def size_hint(blob: Blob) -> int:
    """Half-size of an analysis window that holds the object with room around it."""
    w, h = blob.extent_size
    return max(w, h) // 2 + 4


def _push(kept: deque, ordered: list, value) -> None:
    """Append ``value`` to ``kept`` (the oldest leaving a full deque) and to its sorted copy."""
    if len(kept) == kept.maxlen:
        del ordered[bisect.bisect_left(ordered, kept[0])]
    kept.append(value)
    bisect.insort(ordered, value)


class ObjectHistory:
    """Recent prominences and core areas of the accepted object, and its last core box."""

    def __init__(self, frames: int, min_frames: int) -> None:
        self.min_frames = min_frames
        self.prominences: deque[float] = deque(maxlen=frames)
        self.areas: deque[int] = deque(maxlen=frames)
        self.rel: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self.size_px = 0
        # The same values kept sorted (the medians' statistics.median sorts them every time).
        self._sorted_p: list[float] = []
        self._sorted_a: list[int] = []

    def clear(self) -> None:
        self.prominences.clear()
        self.areas.clear()
        self.rel = (0.0, 0.0, 0.0, 0.0)
        self.size_px = 0
        self._sorted_p, self._sorted_a = [], []

    def add(self, blob: Blob) -> None:
        _push(self.prominences, self._sorted_p, blob.prominence)
        _push(self.areas, self._sorted_a, blob.core_area)
        self.rel = box_rel(blob)
        self.size_px = size_hint(blob)

    def _median(self, ordered: list) -> float | None:
        """statistics.median of the values, once ``min_frames`` are known (None before)."""
        n = len(ordered)
        if n < self.min_frames:
            return None
        if n % 2:
            return ordered[n // 2]
        return (ordered[n // 2 - 1] + ordered[n // 2]) / 2

    @property
    def prominence(self) -> float | None:
        """Median prominence once ``min_frames`` are known (None before)."""
        return self._median(self._sorted_p)

    @property
    def area(self) -> float | None:
        return self._median(self._sorted_a)

    def snapshot(self) -> dict:
        return {
            "prominences": list(self.prominences),
            "areas": list(self.areas),
            "rel": list(self.rel),
            "size_px": self.size_px,
        }

    def restore(self, state: dict) -> None:
        self.prominences.clear()
        self.prominences.extend(float(v) for v in state["prominences"])
        self.areas.clear()
        self.areas.extend(int(v) for v in state["areas"])
        self._sorted_p, self._sorted_a = sorted(self.prominences), sorted(self.areas)
        r = state["rel"]
        self.rel = (float(r[0]), float(r[1]), float(r[2]), float(r[3]))
        self.size_px = int(state["size_px"])


@dataclass
class Candidate:
    """A possible drone found while the track is lost, confirmed frame by frame."""

    x: float
    y: float
    vx: float
    vy: float
    rel: tuple[float, float, float, float]
    prominence: float
    area: int
    size_px: int
    count: int
    cued: bool

    @classmethod
    def of(cls, blob: Blob, *, cued: bool) -> Candidate:
        return cls(
            blob.centroid_x,
            blob.centroid_y,
            0.0,
            0.0,
            box_rel(blob),
            blob.prominence,
            blob.core_area,
            size_hint(blob),
            1,
            cued,
        )

    def predict(self) -> tuple[float, float]:
        return self.x + self.vx, self.y + self.vy

    def follow(self, blob: Blob) -> None:
        """One more confirming frame: the velocity is the last step (two points make a line)."""
        self.vx, self.vy = blob.centroid_x - self.x, blob.centroid_y - self.y
        self.x, self.y = blob.centroid_x, blob.centroid_y
        self.rel = box_rel(blob)
        self.prominence = blob.prominence
        self.area = blob.core_area
        self.size_px = size_hint(blob)
        self.count += 1

    def snapshot(self) -> dict:
        d = asdict(self)
        d["rel"] = list(self.rel)
        return d

    @classmethod
    def from_snapshot(cls, d: dict) -> Candidate:
        r = d["rel"]
        return cls(
            float(d["x"]),
            float(d["y"]),
            float(d["vx"]),
            float(d["vy"]),
            (float(r[0]), float(r[1]), float(r[2]), float(r[3])),
            float(d["prominence"]),
            int(d["area"]),
            int(d["size_px"]),
            int(d["count"]),
            bool(d["cued"]),
        )


def size_ok(area: float, history: ObjectHistory, config: AppearanceConfig) -> bool:
    """A core area within ``size_factor`` of the recent median (areas under 4 px count as 4:
    a point target's core flickers between 1 and 4 pixels)."""
    typical = history.area
    if typical is None:
        return True
    ratio = max(area, 4.0) / max(typical, 4.0)
    return 1.0 / config.size_factor <= ratio <= config.size_factor


def judge(
    blob: Blob | None, pred: tuple[float, float], history: ObjectHistory, config: TrackerConfig
) -> str:
    """Whether the object found near the prediction is the drone: "" or why not (the tracker's
    rule 2, docs/tracking.md)."""
    c, look, strong_snr = config, config.appearance, config.reacquire.snr
    if blob is None:
        return "undefined"
    typical = history.prominence
    if not is_object(blob, c.lost_snr, c.min_isolation):
        # Bright where the drone should be, but not standing out of what it touches: merged
        # with clutter (occluded); else too faint to be seen.
        bright = blob.contrast >= strong_snr * blob.sigma and (
            typical is None or blob.contrast * look.brightness_factor >= typical
        )
        return "occluded" if bright else "faint"
    if (
        typical is not None
        and blob.prominence * look.brightness_factor < typical
        and blob.significance < strong_snr
    ):
        return "faint"
    w, h = blob.core_size
    gate = c.gate_px + max(w, h) / 4.0
    if max(abs(blob.centroid_x - pred[0]), abs(blob.centroid_y - pred[1])) > gate:
        return "gate"
    if typical is not None and blob.prominence > look.brightness_factor * typical:
        return "bright"
    if not size_ok(blob.core_area, history, look):
        return "size"
    return ""


def consistent(blob: Blob, history: ObjectHistory, config: AppearanceConfig) -> bool:
    """A reacquisition candidate looks like the drone: prominence within
    ``brightness_factor`` and core area within ``size_factor`` of its recent history."""
    c = config
    typical = history.prominence
    if typical is not None and not (
        typical / c.brightness_factor <= blob.prominence <= typical * c.brightness_factor
    ):
        return False
    return size_ok(blob.core_area, history, c)
