"""The typed seams between the console and what it drives.

The window (:mod:`snrmon.gui`) drives a live :class:`snrmon.acquisition.runtime.session.Session` or
a recording's :class:`snrmon.acquisition.replay.player.ReplayPlayer` through
:class:`ConsoleSession`; a replay adds :class:`ReplayControls`, and the window tells the two apart
by that protocol, not by an attribute's name. Each camera is a :class:`CameraView`.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from snrmon.acquisition.config import SessionConfig
from snrmon.acquisition.engine.status import CameraStatus, SessionStatus
from snrmon.acquisition.prediction import Predictor
from snrmon.acquisition.stops.table import StopRow
from snrmon.acquisition.streams.ring import RingFrame


class CameraView(Protocol):
    """One camera as a display sees it: frames to draw and numbers to show, never to compute."""

    name: str
    shape: tuple[int, int]

    def latest_frame(self) -> RingFrame | None: ...

    def series(self) -> np.ndarray: ...

    def status(self) -> CameraStatus: ...

    def click_messages(self) -> list[str]:
        """What became of the operator's last click, each message once (none in a replay)."""
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

    def status(self) -> SessionStatus: ...

    def stops(self) -> list[StopRow]: ...

    def set_roi(self, camera: str, x: int, y: int) -> None: ...

    def start_recording(self, path: str | Path) -> None: ...

    def stop_recording(self) -> Any: ...

    def mark_stop(self) -> None: ...

    def capture_reference(self, camera: str, n_frames: int = 64) -> None: ...

    def add_note(self, text: str) -> None: ...


@runtime_checkable
class ReplayControls(Protocol):
    """A replay's transport: play, pause, step, seek, speed, and where it is."""

    def toggle_play(self) -> None: ...

    def step(self, n: int = 1) -> None: ...

    def seek(self, index: int) -> None: ...

    def set_speed(self, speed: float) -> None: ...

    def position(self) -> Any: ...

    def now_ns(self) -> int: ...
