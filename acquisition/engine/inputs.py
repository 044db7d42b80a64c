"""What goes into and comes out of the per-frame engine, as data.

Commands change a camera engine's state; they are posted from any thread and applied by the
engine's owner at the next frame
(:meth:`snrmon.acquisition.engine.camera_engine.CameraEngine.post`), so a measurement never mixes
two ROIs. The frame they took effect on is part of the record: a replay applies the same commands at
the same frames (``roi_set`` events, the measurement row's cue, the recorded background reference,
state snapshots at recording gaps). A command an operator gives names the event it is recorded as
(``EVENT``, with its :meth:`SetRoi.payload`); the others are recorded otherwise (a cue in the
measurement row, a reference as its image) or not at all (a replay's own).

A frame's way through the engine: the ring's :class:`~snrmon.acquisition.streams.ring.RingFrame`
goes in as it is, and :class:`FrameOutput` comes out: that frame, the commands applied before it,
its one :class:`Measurement` (what every listener receives: recorder, stop table, charts, the
HIL rig, live and in replay alike) and a background reference completed on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.acquisition.track.config import TrackState


@dataclass(frozen=True, slots=True)
class SetRoi:
    """The operator's click: measure (and track) around column ``x``, row ``y``."""

    EVENT: ClassVar[str] = "roi_set"
    x: int
    y: int

    def payload(self) -> dict[str, Any]:
        """The recorded event's payload (the recording adds the frame's counter)."""
        return {"x": self.x, "y": self.y}


@dataclass(frozen=True, slots=True)
class ClearRoi:
    """Stop measuring."""

    EVENT: ClassVar[str] = "roi_cleared"

    def payload(self) -> dict[str, Any]:
        return {}


@dataclass(frozen=True, slots=True)
class Cue:
    """The drone's GPS position projected into this camera (px): the tracker reacquires near it."""

    x: float
    y: float


@dataclass(frozen=True, slots=True)
class StartReference:
    """Average the next ``n_frames`` frames (clear sky) into the background reference."""

    EVENT: ClassVar[str] = "reference_started"
    n_frames: int

    def payload(self) -> dict[str, Any]:
        return {}


@dataclass(frozen=True, slots=True)
class ClearReference:
    """Drop the background reference."""

    EVENT: ClassVar[str] = "reference_cleared"

    def payload(self) -> dict[str, Any]:
        return {}


@dataclass(frozen=True, eq=False)
class ApplyReference:
    """A background reference captured before (a replay applies the recorded one)."""

    offset: np.ndarray  # float32 (rows, columns): the fixed-pattern offset subtracted
    summary: dict  # n_frames, first_counter, last_counter, spatial_std_dn
    restart_raw: bool = True  # a capture just completed: the raw-frame track starts here


@dataclass(frozen=True, slots=True)
class Restore:
    """Continue from a recorded engine state (:meth:`CameraEngine.snapshot`)."""

    state: dict


Command = SetRoi | ClearRoi | Cue | StartReference | ClearReference | ApplyReference | Restore
RecordedCommand = SetRoi | ClearRoi | StartReference | ClearReference
"""The commands recorded as an event of their own at the frame they took effect on."""


def recorded_commands(commands: tuple[Command, ...]) -> tuple[RecordedCommand, ...]:
    """Those of ``commands`` a recording keeps as events (:data:`RecordedCommand`)."""
    return tuple(
        c for c in commands if isinstance(c, SetRoi | ClearRoi | StartReference | ClearReference)
    )


@dataclass(frozen=True, slots=True)
class RunningFigures:
    """The running statistics of the per-frame SNR over the last ``window`` valid frames
    (averaged after the SNR is formed, paper section 7; ddof as configured)."""

    mean: float
    std: float
    n: int


@dataclass(frozen=True, slots=True)
class Measurement:
    """One measured frame, the one result that flows from the measurer to every listener
    (recorder, stop table, charts, console status, the HIL rig), live and in replay alike:
    Eq. (4) with the track, the running statistics after it, the range at the frame's time, and
    the cue applied before it (None: none). Built once, by
    :meth:`snrmon.acquisition.engine.frame_measurer.FrameMeasurer.measure` (or read back from a
    recording)."""

    camera: str
    seq: int
    counter: int
    t_host_ns: int
    result: PeakSnr
    track_state: TrackState
    window_xy: tuple[int, int]
    snr_mean: float
    snr_std: float
    snr_n: int
    range_m: float | None
    range_source: str
    cue_xy: tuple[float, float] | None = None
    # the running statistics of the same track on the raw frames, while a correction is on
    # (None: no correction, or a replay that does not track the raw frames)
    raw: RunningFigures | None = None
    track_reason: str = ""  # why the tracker did not find the drone in this frame ("": it did)


@dataclass(frozen=True, slots=True)
class ReferenceDone:
    """A background reference completed on this frame: its offset image and summary."""

    offset: np.ndarray
    summary: dict


@dataclass(frozen=True, slots=True)
class FrameOutput:
    """What one frame did: the frame itself (as the ring gave it), its measurement (None without
    an ROI), the commands applied before it (for the record), and a background reference
    completed on it."""

    frame: RingFrame
    measurement: Measurement | None
    applied: tuple[Command, ...] = ()
    reference_done: ReferenceDone | None = None
