"""The real thermal drone clips of ``tests/data/ir_small_targets`` as a tracking benchmark.

33 clips (320x256, 8-bit AGC'd video, 30 fps) with one labelled box per frame (PROVENANCE.md
there). Per clip and click, the tracker runs from a deterministic click off the box's centre and
every labelled frame is scored:

- **Box**: MATLAB's 1-based ``x, y, w, h`` of ``labels_csv/*.csv`` in zero-based pixel-centre
  coordinates spans columns ``x - 1 .. x - 1 + w`` and rows ``y - 1 .. y - 1 + h``; a peak is
  *inside* when it is within that box grown by ``MARGIN_PX`` (2) on every side.
- **Clicks**: the box's centre moved 3 px right, left, down, up, 2 px diagonally down-right and
  up-left, and 3 px towards the nearest clutter pixel (>= ``CLUTTER_DN`` = 200, outside the
  box grown by 2 px) of the first frame: seven clicks, all within 3 px of the centre.
- **Not separable from saturated clutter** (:func:`inseparable`): the drone's bright pixels
  (>= ``CLUTTER_DN`` in the middle half of the box: a loose label reaches into the treeline at
  its edges) are connected (8-neighbours, >= ``CLUTTER_DN``) to pixels
  farther than ``MARGIN_PX`` outside the box: the drone has merged with a bright treeline or
  cloud edge and no tracker can tell where it ends. A dim drone (no pixel >= 200) never
  merges by this rule.
- **Correct frame**: separable: the track claims the drone (state ``tracking``, ``gps_cued``
  or ``reacquiring``) and its peak is inside the box; inseparable: the track says it does not
  have the drone (state ``lost``, ``occluded`` or ``reacquiring``) rather than sitting on the
  clutter.
- **Baseline**: the brightest pixel of a 21 x 21 window around its last position (first in
  row-major order among equals), from the same click; it never says it lost anything, so it
  scores no inseparable frame.

Also counted: frames LOST (``lost`` or ``reacquiring``), frames ``occluded``, reacquisitions, and
the longest run of separable frames the track missed (how long a visible drone stayed lost).
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from snrmon.acquisition.replay.stack_io import open_video
from snrmon.acquisition.track.tracker import Tracker, TrackState

MARGIN_PX = 2
CLUTTER_DN = 200
BASELINE_HALF_PX = 10  # 21 x 21
CLAIMS = frozenset({TrackState.TRACKING, TrackState.GPS_CUED, TrackState.REACQUIRING})
DISCLAIMS = frozenset({TrackState.LOST, TrackState.OCCLUDED, TrackState.REACQUIRING})
OFFSETS: tuple[tuple[str, tuple[int, int]], ...] = (
    ("right", (3, 0)),
    ("left", (-3, 0)),
    ("down", (0, 3)),
    ("up", (0, -3)),
    ("down_right", (2, 2)),
    ("up_left", (-2, -2)),
)


def data_root(folder: str = "ir_small_targets") -> Path:
    """``$SNRMON_TEST_DATA/<folder>``, else the checkout's ``tests/data/<folder>`` (the real
    data with its provenance; an installed package has no checkout: set the variable)."""
    base = os.environ.get("SNRMON_TEST_DATA")
    root = Path(base) if base else Path(__file__).resolve().parents[1] / "tests" / "data"
    return root / folder


def clip_names(root: Path | None = None) -> list[str]:
    """The clips of ``clips.csv``, in its order; a clear error when the data is not there."""
    root = root or data_root()
    table = root / "clips.csv"
    if not table.is_file():
        raise FileNotFoundError(
            f"real clips not found: {table} "
            "(set SNRMON_TEST_DATA to a folder holding ir_small_targets/)"
        )
    with open(table, newline="") as fh:
        return [row["clip"] for row in csv.DictReader(fh)]


def load_clip(name: str, root: Path | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(frames (N, H, W) uint8, boxes (N, 4) float: x0, y0, x1, y1 zero-based, inclusive)."""
    root = root or data_root()
    cap = open_video(root / "videos" / f"{name}.mp4")
    frames = []
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            frames.append(frame[:, :, 0].copy() if frame.ndim == 3 else frame)
    finally:
        cap.release()
    labels = np.loadtxt(root / "labels_csv" / f"{name}.csv", delimiter=",", skiprows=1, ndmin=2)
    if not frames or len(labels) != len(frames):
        raise ValueError(f"{name}: {len(frames)} decoded frames but {len(labels)} labels")
    x0, y0 = labels[:, 2] - 1.0, labels[:, 3] - 1.0
    boxes = np.stack([x0, y0, x0 + labels[:, 4], y0 + labels[:, 5]], axis=1)
    return np.stack(frames), boxes


def inside(x: float, y: float, box: np.ndarray, margin: float = MARGIN_PX) -> bool:
    return box[0] - margin <= x <= box[2] + margin and box[1] - margin <= y <= box[3] + margin


def inseparable(frame: np.ndarray, box: np.ndarray) -> bool:
    """The rule of the module docstring: the drone's bright pixels join bright clutter."""
    rows, cols = frame.shape
    m = MARGIN_PX
    # The drone's own pixels: the bright ones in the middle half of the box (a loose label
    # reaches into the treeline at its edges).
    qw, qh = (box[2] - box[0]) / 4.0, (box[3] - box[1]) / 4.0
    bx0, by0 = max(math.ceil(box[0] + qw), 0), max(math.ceil(box[1] + qh), 0)
    bx1, by1 = min(math.floor(box[2] - qw), cols - 1), min(math.floor(box[3] - qh), rows - 1)
    drone = frame[by0 : by1 + 1, bx0 : bx1 + 1] >= CLUTTER_DN
    if not drone.any():
        return False
    # Components in a window with room around the box: enough to see them leave it.
    pad = 4 * m
    wx0, wy0 = max(math.floor(box[0]) - pad, 0), max(math.floor(box[1]) - pad, 0)
    wx1, wy1 = min(math.ceil(box[2]) + pad, cols - 1), min(math.ceil(box[3]) + pad, rows - 1)
    bright = (frame[wy0 : wy1 + 1, wx0 : wx1 + 1] >= CLUTTER_DN).astype(np.uint8)
    _, labels = cv2.connectedComponents(bright, connectivity=8)
    inner = labels[by0 - wy0 : by1 - wy0 + 1, bx0 - wx0 : bx1 - wx0 + 1][drone]
    ours = np.isin(labels, np.unique(inner[inner > 0]))
    yy, xx = np.nonzero(ours)
    xx, yy = xx + wx0, yy + wy0
    outside = (xx < box[0] - m) | (xx > box[2] + m) | (yy < box[1] - m) | (yy > box[3] + m)
    return bool(outside.any())


def clicks(frame: np.ndarray, box: np.ndarray) -> list[tuple[str, tuple[int, int]]]:
    """The seven deterministic clicks of the module docstring (name, (x, y))."""
    cx, cy = (box[0] + box[2]) / 2.0, (box[1] + box[3]) / 2.0
    out = [(name, (round(cx + dx), round(cy + dy))) for name, (dx, dy) in OFFSETS]
    yy, xx = np.nonzero(frame >= CLUTTER_DN)
    far = ~((xx >= box[0] - 2) & (xx <= box[2] + 2) & (yy >= box[1] - 2) & (yy <= box[3] + 2))
    if far.any():
        d = np.hypot(xx[far] - cx, yy[far] - cy)
        i = int(np.argmin(d))
        ux, uy = (xx[far][i] - cx) / d[i], (yy[far][i] - cy) / d[i]
        dx, dy = round(3 * ux), round(3 * uy)
        if math.hypot(dx, dy) > 3:  # (2, 3) and the like: keep within 3 px
            dx, dy = math.trunc(3 * ux), math.trunc(3 * uy)
        out.append(("to_clutter", (round(cx + dx), round(cy + dy))))
    return out


def baseline_track(frames: np.ndarray, at: tuple[int, int]) -> list[tuple[int, int]]:
    """The trivial tracker: brightest pixel of a 21 x 21 window around the last position."""
    x, y = at
    rows, cols = frames.shape[1:]
    h = BASELINE_HALF_PX
    out = []
    for f in frames:
        x0, x1 = max(x - h, 0), min(x + h, cols - 1)
        y0, y1 = max(y - h, 0), min(y + h, rows - 1)
        win = f[y0 : y1 + 1, x0 : x1 + 1]
        i = int(np.argmax(win))
        x, y = x0 + i % win.shape[1], y0 + i // win.shape[1]
        out.append((x, y))
    return out


@dataclass(frozen=True)
class RunScore:
    """One clip from one click."""

    clip: str
    click: str
    at: tuple[int, int]
    frames: int
    inseparable: int
    fraction: float  # correct frames / labelled frames
    baseline: float
    lost: int
    occluded: int
    reacquisitions: int
    longest_miss: int  # longest run of separable frames not on the drone


def score_run(
    name: str,
    frames: np.ndarray,
    boxes: np.ndarray,
    click: tuple[str, tuple[int, int]],
    merged: list[bool],
    tracker_factory=Tracker,
) -> RunScore:
    label, at = click
    tracker = tracker_factory(at)
    correct = 0
    lost = occluded = 0
    run = longest = 0
    for frame, box, joined in zip(frames, boxes, merged, strict=True):
        step = tracker.update(frame)
        m = step.peak_snr
        if joined:
            ok = step.state in DISCLAIMS
        else:
            ok = step.state in CLAIMS and inside(m.peak_x, m.peak_y, box)
            run = 0 if ok else run + 1
            longest = max(longest, run)
        correct += ok
        lost += step.state in (TrackState.LOST, TrackState.REACQUIRING)
        occluded += step.state is TrackState.OCCLUDED
    base = baseline_track(frames, at)
    base_ok = sum(
        (not joined) and inside(x, y, box)
        for (x, y), box, joined in zip(base, boxes, merged, strict=True)
    )
    n = len(frames)
    return RunScore(
        name,
        label,
        at,
        n,
        sum(merged),
        correct / n,
        base_ok / n,
        lost,
        occluded,
        tracker.reacquisitions,
        longest,
    )


def score_clip(name: str, root: Path | None = None, tracker_factory=Tracker) -> list[RunScore]:
    """Every click of one clip."""
    frames, boxes = load_clip(name, root)
    merged = [inseparable(f, b) for f, b in zip(frames, boxes, strict=True)]
    return [
        score_run(name, frames, boxes, click, merged, tracker_factory)
        for click in clicks(frames[0], boxes[0])
    ]
