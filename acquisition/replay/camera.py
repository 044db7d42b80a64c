"""One recorded camera as the console sees a live one
(:class:`snrmon.acquisition.protocols.CameraView`):
its shape, the frame shown last, and the numbers of the engine the replay runs."""

from __future__ import annotations

import threading

import numpy as np

from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.status import CameraStatus, FrameAccounting
from snrmon.acquisition.streams.delivered_rate import DeliveredRate
from snrmon.acquisition.streams.ring import RingFrame


class ReplayCamera:
    """A recorded camera's view for the console (state set by the replay worker)."""

    def __init__(self, name: str, engine: CameraEngine, fps: float) -> None:
        self.name = name
        self.shape = engine.shape
        self.fps = fps  # the recording's frame rate
        # the frames the replay delivers per second (its speed, its pauses): the status's fps
        self.delivered = DeliveredRate()
        self.engine = engine
        self._lock = threading.Lock()
        self._latest: RingFrame | None = None
        self._shown = 0

    def rebind(self, engine: CameraEngine) -> None:
        """The replay restarted (a seek) with a fresh engine."""
        with self._lock:
            self.engine = engine
            self._latest = None
            self._shown = 0

    def show(self, frame: RingFrame) -> None:
        """The replay worker's frame (its thread): the one the console shows next."""
        self.delivered.frame(frame.seq)
        with self._lock:
            self._latest = frame
            self._shown += 1

    def apparent_temp_k(self, x: int, y: int, dn: float) -> float | None:
        """Pixel (x, y)'s raw ``dn`` as an apparent temperature (K); None uncalibrated."""
        with self._lock:
            engine = self.engine
        return engine.apparent_temp_k(x, y, dn)

    def click_messages(self) -> list[str]:
        """A replay re-measures a click on the shown frame at once: it has nothing to tell."""
        return []

    def latest_frame(
        self, *, unless_seq: int | None = None, out: np.ndarray | None = None
    ) -> RingFrame | None:
        """The frame shown last (its own array: ``out`` is not needed); None when there is
        none, or when its ``seq`` is ``unless_seq``."""
        with self._lock:
            latest = self._latest
        return None if latest is None or latest.seq == unless_seq else latest

    def series(self) -> np.ndarray:
        """Rows of (t_host_ns, snr, running mean, running std, range_m or NaN), as live."""
        with self._lock:
            engine = self.engine
        return engine.series()

    def status(self) -> CameraStatus:
        with self._lock:
            engine, shown = self.engine, self._shown
        # every frame shown is one of the file's, measured again
        frames = FrameAccounting(received=shown, written=shown)
        base = engine.status()
        return base.with_frames(base.device, frames, self.delivered.per_s())
