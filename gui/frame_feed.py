"""Each camera's frames for its view, made ready off the GUI thread: every frame the camera
delivers, as long as the display keeps up, and the count of frames shown against frames delivered
when it does not.

The worker fills buffers, the GUI timer draws. A :class:`DisplayWorker` thread asks each
:class:`FrameFeed` to :meth:`~FrameFeed.prepare` the camera's newest frame once the view has taken
the last one: the frame is copied into one of three arrays the feed keeps (a fresh 1.8 MB array
per frame would cost its page faults on every frame), its display levels are taken (robust
percentiles, :class:`snrmon.gui.levels.AutoLevels`, while auto-levels is on; once a second the
levels control's histogram) and the image the
screen shows is made from it (reduced and coloured in one compiled pass that releases the
interpreter lock, :mod:`snrmon.gui.display_image`) at the reduction and colours the view last
drew with (its :class:`DisplayRequest`). The main window's frame timer ticks every few ms
(``FRAME_INTERVAL_MS``) and hands the ready frame to its view, which only wraps the made image and
paints it: the percentiles and the colouring, ~1 ms a frame at 60 frames/s, no longer hold the
event loop.

The camera's ``seq`` numbers the frames it delivered: a jump of more than one between two frames
shown is frames the display skipped (its event loop was late by a whole frame period), counted
and shown in the status bar (:func:`display_message`), not silently dropped.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from snrmon.acquisition.protocols import CameraView
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.gui.display_image import colour_table, shown_rgb32
from snrmon.gui.levels import AutoLevels, display_histogram

log = logging.getLogger(__name__)

BUFFERS = 3  # the frame shown, the one drawn before it, and the next one
PREPARE_INTERVAL_S = 0.002  # how often the worker looks for a new frame (a lock and a compare)
# The levels control's histogram is taken of a frame this often (s); each new one repaints the
# control, the costliest paint of a camera view (~7 ms of CPU at the 99th percentile).
HISTOGRAM_EVERY_S = 1.0


@dataclass(frozen=True)
class DisplayRequest:
    """How the view draws its frames, for the worker to make them so (set on the GUI thread,
    read on the worker's; replaced whole, never changed in place)."""

    x_factor: int
    """Camera columns averaged into one shown column."""
    y_factor: int
    """Camera rows averaged into one shown row."""
    lut: np.ndarray | None = field(compare=False)
    """The colour map ((N, 3 or 4) uint8), None for grey (compared by ``lut_key``)."""
    lut_key: bytes | None
    """``lut``'s bytes: what the made image's key compares."""
    auto_levels: bool
    """Levels from each frame's percentiles (else ``levels``)."""
    levels: tuple[float, float]
    """The operator's levels (DN) while auto-levels is off."""
    auto_generation: int = 0
    """Raised each time auto-levels is asked for again: the next levels found apply at once."""


@dataclass(frozen=True)
class ShownFrame:
    """A frame made ready for its view."""

    frame: RingFrame
    levels: tuple[float, float]
    """The display levels (DN) the image was coloured with."""
    image: np.ndarray | None = None
    """The screen's image (rows x columns, 0xffRRGGBB uint32), None if none was asked for."""
    image_key: tuple | None = None
    """(x_factor, y_factor, levels, lut_key, n_values) of ``image``: the view uses it only if
    it draws with the same."""
    histogram: tuple[np.ndarray, np.ndarray] | None = None
    """The levels control's new histogram of this frame (bins' left edges in DN, counts;
    :func:`snrmon.gui.levels.display_histogram`), None between two (every
    :data:`HISTOGRAM_EVERY_S`)."""


class FrameFeed:
    """The newest frames of one camera for its view, and how many were shown of those
    delivered (since the feed began). :meth:`prepare` runs on the worker's thread,
    :meth:`newest` on the GUI's."""

    def __init__(self, camera: CameraView) -> None:
        self.camera = camera
        self.request: DisplayRequest | None = None
        self.shown = 0
        self.delivered = 0
        self._lock = threading.Lock()
        self._ready: tuple[int, ShownFrame] | None = None  # (slot, frame) not taken yet
        self._shown_slots: tuple[int, int] = (-1, -1)  # the slots shown now and before
        self._pixels: list[np.ndarray] = []
        self._images: list[np.ndarray | None] = [None] * BUFFERS
        self._prepared_seq: int | None = None
        self._last_seq: int | None = None
        self._levels = AutoLevels()
        self._table_for: tuple | None = None
        self._table: np.ndarray | None = None
        self._histogram_due = 0.0  # monotonic s

    # ------------------------------------------------------------------ worker thread
    def prepare(self) -> bool:
        """Make the camera's newest frame ready for the view, if the view has taken the last
        one and the camera has a newer one; returns whether a frame was made ready."""
        with self._lock:
            if self._ready is not None:
                return False
            busy = self._shown_slots
        slot = next(i for i in range(BUFFERS) if i not in busy)
        out = self._pixels[slot] if self._pixels else None
        frame = self.camera.latest_frame(unless_seq=self._prepared_seq, out=out)
        if frame is None:
            return False
        if not self._pixels and frame.pixels.ndim == 2:
            self._pixels = [np.empty_like(frame.pixels) for _ in range(BUFFERS)]
        self._prepared_seq = frame.seq
        shown = self._made_ready(frame, slot, self.request)
        now = time.monotonic()
        if now >= self._histogram_due:
            self._histogram_due = now + HISTOGRAM_EVERY_S
            shown = dataclasses.replace(shown, histogram=display_histogram(frame.pixels))
        with self._lock:
            self._ready = (slot, shown)
        return True

    def _made_ready(self, frame: RingFrame, slot: int, req: DisplayRequest | None) -> ShownFrame:
        pixels = frame.pixels
        if req is None:  # the view has not drawn yet: its first frame is made on its side
            return ShownFrame(frame, self._levels.levels_of(pixels, True, (0.0, 1.0), 0))
        levels = self._levels.levels_of(pixels, req.auto_levels, req.levels, req.auto_generation)
        if pixels.ndim != 2 or pixels.dtype not in (np.uint8, np.uint16):
            return ShownFrame(frame, levels)
        rows, cols = pixels.shape[0] // req.y_factor, pixels.shape[1] // req.x_factor
        if rows == 0 or cols == 0:
            return ShownFrame(frame, levels)
        n_values = 1 << (8 * pixels.dtype.itemsize)
        key = (req.x_factor, req.y_factor, levels, req.lut_key, n_values)
        table_for = key[2:]
        if table_for != self._table_for:
            self._table = colour_table(levels, req.lut, n_values)
            self._table_for = table_for
        image = self._images[slot]
        if image is None or image.shape != (rows, cols):
            image = self._images[slot] = np.empty((rows, cols), np.uint32)
        shown_rgb32(pixels, req.x_factor, req.y_factor, self._table, image)
        return ShownFrame(frame, levels, image, key)

    # ------------------------------------------------------------------ GUI thread
    def newest(self) -> ShownFrame | None:
        """The frame made ready since the view last took one, else None."""
        with self._lock:
            ready, self._ready = self._ready, None
            if ready is None:
                return None
            slot, shown = ready
            self._shown_slots = (slot, self._shown_slots[0])
        seq = shown.frame.seq
        last, self._last_seq = self._last_seq, seq
        # Frames delivered since the last one shown; a seq that did not grow is a restart
        # (a replay's seek): one frame.
        self.delivered += seq - last if last is not None and seq > last else 1
        self.shown += 1
        return shown


class DisplayWorker:
    """The thread that prepares every feed's frames (:meth:`FrameFeed.prepare`), looking for
    new ones every :data:`PREPARE_INTERVAL_S`."""

    def __init__(self, feeds: Iterable[FrameFeed], interval_s: float = PREPARE_INTERVAL_S) -> None:
        self.feeds = list(feeds)
        self.interval_s = interval_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="display-worker", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)

    def _run(self) -> None:
        failed: set[int] = set()
        while not self._stop.wait(self.interval_s):
            for k, feed in enumerate(self.feeds):
                try:
                    feed.prepare()
                    failed.discard(k)
                except Exception:  # a bad frame must not stop the display
                    if k not in failed:  # once per failure, not at every look
                        name = getattr(feed.camera, "name", k)
                        log.exception("display of %s: a frame could not be made ready", name)
                    failed.add(k)


class DisplayRates:
    """Frames shown and delivered per second per camera over the last ``window_s`` seconds."""

    def __init__(self, window_s: float = 5.0) -> None:
        self.window_s = window_s
        self._samples: deque[tuple[float, dict[str, tuple[int, int]]]] = deque()

    def sample(self, feeds: dict[str, FrameFeed]) -> dict[str, tuple[float, float]]:
        """Record the counts now; {camera: (shown per s, delivered per s)} over the window."""
        now = time.monotonic()
        self._samples.append((now, {n: (f.shown, f.delivered) for n, f in feeds.items()}))
        while len(self._samples) > 2 and now - self._samples[1][0] >= self.window_s:
            self._samples.popleft()
        t0, first = self._samples[0]
        span = now - t0
        if span <= 0:
            return {}
        return {
            n: ((f.shown - first[n][0]) / span, (f.delivered - first[n][1]) / span)
            for n, f in feeds.items()
            if n in first
        }


def display_message(rates: dict[str, tuple[float, float]]) -> tuple[str, bool]:
    """The status bar's text of the frames shown / delivered, and whether frames are being
    skipped (the display shows fewer than the cameras deliver)."""
    if not rates:
        return "", False
    parts = [f"{n.upper()} {shown:.1f}/{delivered:.1f}" for n, (shown, delivered) in rates.items()]
    skipping = any(delivered - shown >= 0.5 for shown, delivered in rates.values())
    text = "frames shown/delivered per s: " + ", ".join(parts)
    return (text + "  (the display is skipping frames)" if skipping else text), skipping
