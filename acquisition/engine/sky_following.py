"""The model's background following each camera's measured sky temperature (paper sections 8-9:
the path-radiance correction), owned by the session's engine alone.

The engine looks at a camera's apparent sky temperature (the mean over its last 100 frames) at
most every :data:`SKY_CHECK_NS` and follows it on a change larger than :data:`SKY_CHANGE_K`; a
replay applies the changes the live session recorded instead. Whoever hands the session a new
predictor (the console's model options) gets the followed sky carried over to it
(:meth:`SkyFollower.apply_to`); a display reads the followed temperature
(:meth:`SkyFollower.temp_k`) and never sets one.
"""

from __future__ import annotations

import math
import threading

from snrmon.acquisition.calibrate.sky_temperature import SkyTemperature
from snrmon.acquisition.prediction import Predictor

SKY_CHECK_NS = 2_000_000_000  # the model's background is re-evaluated at most every 2 s
SKY_CHANGE_K = 0.5  # ... and follows the sky only on a change larger than this
SKY_FRAMES = 100  # the sky temperature followed: the mean over the last 100 frames


class SkyFollower:
    """The sky temperature (K) the model's background follows, per camera (module docstring).
    :meth:`follow` runs on a camera's frame thread; the rest on any thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._checked_ns: dict[str, int] = {}
        self._temp_k: dict[str, float] = {}

    def temp_k(self, camera: str) -> float | None:
        """The sky temperature ``camera``'s model background follows now (None: the model's
        own, not following yet)."""
        with self._lock:
            return self._temp_k.get(camera)

    def follow(
        self, camera: str, t_ns: int, sky: SkyTemperature, predictor: Predictor
    ) -> float | None:
        """At frame time ``t_ns``: the new background temperature (K) set on ``predictor``
        when ``camera``'s measured sky moved enough since the last one, else None."""
        if t_ns - self._checked_ns.get(camera, 0) < SKY_CHECK_NS:
            return None
        temp = sky.mean_temp_k(last=SKY_FRAMES)
        if not math.isfinite(temp):
            return None  # not measured yet: look again next frame, not in 2 s
        self._checked_ns[camera] = t_ns
        current = self.temp_k(camera)
        if current is None:  # not followed yet: the background the predictor was built with
            current = predictor.background_temp_k.get(camera)
        if current is not None and abs(temp - current) <= SKY_CHANGE_K:
            return None
        self.set(camera, temp, predictor)
        return temp

    def set(self, camera: str, temp_k: float | None, predictor: Predictor | None) -> None:
        """``camera``'s model background is ``temp_k`` from now on (a recorded change a replay
        applies, or one followed; None: the model's own)."""
        with self._lock:
            if temp_k is None:
                self._temp_k.pop(camera, None)
            else:
                self._temp_k[camera] = float(temp_k)
        if predictor is not None:
            predictor.set_background(camera, temp_k)

    def apply_to(self, predictor: Predictor | None) -> None:
        """A predictor the session is handed takes over the sky followed so far."""
        if predictor is None:
            return
        with self._lock:
            temps = dict(self._temp_k)
        for camera, temp in temps.items():
            predictor.set_background(camera, temp)
