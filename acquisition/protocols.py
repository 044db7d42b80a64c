"""The typed seams: between the console and what it drives, and between the live pipeline
and the recording it writes.

The window (:mod:`snrmon.gui`) drives a live :class:`snrmon.acquisition.runtime.session.Session` or
a recording's :class:`snrmon.acquisition.replay.player.ReplayPlayer` through
:class:`ConsoleSession`; a replay adds :class:`ReplayControls`, and the window tells the two apart
by that protocol, not by an attribute's name. Each camera is a :class:`CameraView`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from snrmon.acquisition.config import SessionConfig
from snrmon.acquisition.engine.inputs import Measurement
from snrmon.acquisition.engine.status import CameraStatus, SessionStatus
from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.prediction import MeasuredNoise, ModelRequest, Predictor, Weather
from snrmon.acquisition.record.recorder_status import RecorderStatus, RecorderSummary
from snrmon.acquisition.stops.table import StopRow
from snrmon.acquisition.streams.ring import Reader, RingFrame
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading


class CameraView(Protocol):
    """One camera as a display sees it: frames to draw and numbers to show, never to compute."""

    name: str
    shape: tuple[int, int]

    def latest_frame(
        self, *, unless_seq: int | None = None, out: np.ndarray | None = None
    ) -> RingFrame | None:
        """The newest frame (possibly copied into ``out``); None when there is none, or when
        its ``seq`` is ``unless_seq`` (the display has it)."""
        ...

    def series(self) -> np.ndarray: ...

    def status(self) -> CameraStatus: ...

    def click_messages(self) -> list[str]:
        """What became of the operator's last click, each message once (none in a replay)."""
        ...

    def apparent_temp_k(self, x: int, y: int, dn: float) -> float | None:
        """Pixel (x, y)'s raw value ``dn`` as an apparent temperature (K) by the camera's
        calibration; None without one."""
        ...


class ConsoleSession(Protocol):
    """What the console window needs of a session, live or replayed."""

    config: SessionConfig

    @property
    def pipelines(self) -> Mapping[str, CameraView]: ...

    @property
    def predictor(self) -> Predictor | None: ...

    @predictor.setter
    def predictor(self, predictor: Predictor | None) -> None: ...

    @property
    def reference_predictor(self) -> Predictor | None:
        """The model at its own background beside :attr:`predictor` (None: not asked for)."""
        ...

    def set_model(self, request: ModelRequest, *, reference_only: bool = False) -> None:
        """Build the model the operator asked for (the session's engine does; a ValueError
        changes nothing): :attr:`predictor` and :attr:`reference_predictor`, or with
        ``reference_only`` the reference alone."""
        ...

    def status(self) -> SessionStatus: ...

    def model_sky_temp_k(self, camera: str) -> float | None:
        """The measured sky temperature (K) ``camera``'s model background follows (None: the
        model's own); the session's engine alone sets it."""
        ...

    def stops(self) -> list[StopRow]: ...

    def set_roi(self, camera: str, x: int, y: int) -> None: ...

    def clear_roi(self, camera: str) -> None: ...

    def start_recording(self, path: str | Path) -> None: ...

    def stop_recording(self) -> Any: ...

    def mark_stop(self) -> None: ...

    def capture_reference(self, camera: str, n_frames: int = 64) -> None: ...

    def add_note(self, text: str) -> None: ...

    @property
    def met_readings(self) -> Weather | None:
        """The day's met readings the model uses (None: the model's own atmosphere)."""
        ...

    def set_met_readings(self, weather: Weather) -> None: ...

    @property
    def measured_noise(self) -> Mapping[str, MeasuredNoise]:
        """Per camera, the measured 3D noise the model uses in place of its own (a camera not
        in it: the model's noise)."""
        ...

    def set_measured_noise(self, camera: str, noise: MeasuredNoise | None) -> None:
        """``camera``'s measured noise for the model (None: the model's own again)."""
        ...


@runtime_checkable
class ReplayControls(Protocol):
    """A replay's transport: play, pause, step, seek, speed, and where it is."""

    def toggle_play(self) -> None: ...

    def step(self, n: int = 1) -> None: ...

    def seek(self, index: int) -> None: ...

    def set_speed(self, speed: float) -> None: ...

    def position(self) -> Any: ...

    def now_ns(self) -> int: ...


class RecordingWriter(Protocol):
    """What the live pipeline hands a recording, in the manner of ophyd-async's
    ``DetectorWriter``: the pipeline and the session never touch the file, only this
    (:class:`snrmon.acquisition.record.recorder.SessionRecorder` writes the HDF5 session file).
    Every ``add_*`` returns at once (the writing happens on the recording's own thread); a
    frame or reference index is None when the recording did not keep it."""

    path: Path

    def add_frame(self, camera: str, frame: Any) -> int | None: ...

    def add_measurement(
        self,
        camera: str,
        index: int | None,
        m: Measurement | PeakSnr,
        *,
        counter: int = -1,
        t_host_ns: int | None = None,
    ) -> None: ...

    def add_state(
        self, camera: str, counter: int, t_host_ns: int, state: Mapping[str, Any]
    ) -> None: ...

    def add_reference(
        self, camera: str, offset: np.ndarray, summary: Mapping[str, Any], *, t_host_ns: int
    ) -> int | None: ...

    def add_range(self, reading: RangeReading) -> None: ...

    def add_gps(self, fix: GpsFix) -> None: ...

    def add_event(
        self,
        kind: str,
        *,
        camera: str = "",
        payload: Mapping[str, Any] | None = None,
        t_host_ns: int | None = None,
    ) -> None: ...

    def attach_reader(self, camera: str, reader: Reader) -> None: ...

    @property
    def accepting(self) -> bool: ...

    def frames_of(self, camera: str) -> tuple[int, int, dict[str, int]]:
        """(frames given, frames written, frames dropped by reason) of ``camera`` so far."""
        ...

    def status(self) -> RecorderStatus: ...

    def stop(
        self,
        timeout: float = 60.0,
        *,
        accounting: Callable[[], Mapping[str, Mapping]] | None = None,
        devices_lost: Callable[[], list[dict]] | None = None,
    ) -> RecorderSummary: ...
