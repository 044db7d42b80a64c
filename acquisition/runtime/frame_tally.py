"""One camera's frame counts on their way through the live pipeline, and its drop warnings.

:class:`FrameTally` counts what the ring and the recorder do not: frames of the wrong shape, frames
taken for measurement, and where a recording began. :meth:`FrameTally.accounting` joins them with
the ring's and the recorder's own counts into the one
:class:`~snrmon.acquisition.engine.status.FrameAccounting` the console's status, the recording's
``summary_json`` and a replay's report share. :class:`DropWarnings` turns growing drop counts
into at most one warning a second.
"""

from __future__ import annotations

import threading
import time

from snrmon.acquisition.engine.status import FrameAccounting
from snrmon.acquisition.streams.ring import RING_OVERRUN

DROP_REPORT_S = 1.0  # a drop warning at most this often per camera


class FrameTally:
    """The counts of one camera's frames the pipeline keeps itself (any thread).

    The device thread counts a frame of the wrong shape (:meth:`wrong_shape_frame`); the
    measurement thread each frame it takes from the ring (:meth:`taken`); a recording's start
    (:meth:`recording_began`) remembers how many frames were done with before it."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._wrong_shape = 0
        self._taken = 0  # frames taken from the ring for measurement
        self._given = 0  # of them, while the current recording was attached
        self._taken_before = 0  # taken before the current recording began
        self._overruns_before = 0  # ring overruns before the current recording began

    def wrong_shape_frame(self) -> None:
        with self._lock:
            self._wrong_shape += 1

    @property
    def wrong_shape(self) -> int:
        """Frames of the wrong shape so far."""
        with self._lock:
            return self._wrong_shape

    def taken(self, recording: bool) -> None:
        """A frame was taken from the ring; ``recording``: it goes to the recording."""
        with self._lock:
            self._taken += 1
            self._given += int(recording)

    def recording_began(self, overruns: int) -> None:
        """A recording begins now, after ``overruns`` ring overruns."""
        with self._lock:
            self._given = 0
            self._taken_before = self._taken
            self._overruns_before = int(overruns)

    def accounting(
        self,
        *,
        pushed: int,
        overruns: int,
        lag: int,
        camera_gap: int,
        recorded: tuple[int, dict[str, int]] | None,
    ) -> FrameAccounting:
        """The accounting from the ring's counts (frames ``pushed``, the measurement reader's
        ``overruns`` and ``lag``), the camera's ``camera_gap`` and, for a recording, what its
        recorder ``recorded`` of this camera (frames written, dropped by reason); None: no
        recording. Frames given to the recorder and not yet written are ``queued``."""
        with self._lock:
            wrong, taken, given = self._wrong_shape, self._taken, self._given
            taken_before, overruns_before = self._taken_before, self._overruns_before
        received = int(pushed) + wrong
        if recorded is None:  # no recording: every frame measured was not recorded
            return FrameAccounting(
                received=received,
                dropped={RING_OVERRUN: int(overruns)},
                before_recording=taken,
                queued=int(lag),
                wrong_shape=wrong,
                camera_gap=int(camera_gap),
            )
        written, rec_drops = recorded
        return FrameAccounting(
            received=received,
            written=int(written),
            dropped={RING_OVERRUN: int(overruns) - overruns_before, **rec_drops},
            before_recording=taken_before + overruns_before,
            after_recording=taken - taken_before - given,  # a session that went on after it
            queued=int(lag) + given - int(written) - sum(rec_drops.values()),
            wrong_shape=wrong,
            camera_gap=int(camera_gap),
        )


class DropWarnings:
    """Which drops of one camera were warned about: a warning is :meth:`due` at most once every
    :data:`DROP_REPORT_S` (or when ``final``); :meth:`new` gives the drops since the last one."""

    def __init__(self) -> None:
        self._lock = threading.Lock()  # the measurement thread and a detach both report
        self._reported: dict[str, int] = {}  # drops by reason already warned about
        self._last = 0.0

    def due(self, *, final: bool = False) -> bool:
        """Time to look for new drops (checked before the counts are gathered: every frame)."""
        return final or time.monotonic() - self._last >= DROP_REPORT_S

    def new(self, totals: dict[str, int]) -> dict[str, int] | None:
        """The drops of ``totals`` (by reason, since the start) not warned about yet, now
        counted as warned; None when nothing is new."""
        with self._lock:
            self._last = time.monotonic()
            new = {k: v - self._reported.get(k, 0) for k, v in totals.items()}
            new = {k: v for k, v in new.items() if v > 0}
            if not new:
                return None
            self._reported = dict(totals)
            return new

    def recorder_changed(self, keep: tuple[str, ...]) -> None:
        """A new recorder counts its drops from 0: forget all but the reasons ``keep``."""
        with self._lock:
            self._reported = {k: v for k, v in self._reported.items() if k in keep}
