"""One simulated camera watching the flight: frame number -> raw frame (and its truth).

Owns :class:`FlightCameraFeed`, the picklable top-level callable that a camera process runs:
``feed(counter) -> (H, W) uint16``. Frame ``counter`` is taken at ``t_s = t0_s + counter / fps``
of the flight; the drone's range gives its signal electrons (the scene's :class:`TargetSignal`)
and size in pixels, its offset from the line of sight gives its sub-pixel position
(:class:`CameraPointing`). Every frame depends only on (seed, counter), so a dropped or repeated
frame never changes the others.
"""

from __future__ import annotations

import numpy as np

from snrmon.sim.flight import CameraPointing, FlightConfig, FlightPlan
from snrmon.sim.scene import FrameTruth, SceneConfig, SceneRenderer, TargetState


class FlightCameraFeed:
    """A camera of ``scene`` on the flight ``flight``, at ``fps`` frames per second.

    ``t0_s`` is the flight time of frame 0 (negative for a pre-roll before take-off);
    ``launch_s``, when given, is when the drone appears: earlier frames show empty sky.
    """

    def __init__(
        self,
        scene: SceneConfig,
        flight: FlightConfig,
        *,
        fps: float,
        seed: int,
        boresight_offset_px: tuple[float, float] = (0.0, 0.0),
        t0_s: float = 0.0,
        launch_s: float | None = None,
    ):
        if not fps > 0:
            raise ValueError(f"fps must be > 0, got {fps}")
        if scene.target is None and scene.blackbody_e is None:
            raise ValueError(f"scene {scene.name!r} has no target signal to fly")
        self.scene = scene
        self.fps = float(fps)
        self.t0_s = float(t0_s)
        self.launch_s = launch_s
        self.plan = FlightPlan(flight)
        self.pointing = CameraPointing(
            scene.ifov_rad, scene.width_px, scene.height_px, boresight_offset_px
        )
        self.renderer = SceneRenderer(scene, seed)

    def time_of(self, counter: int) -> float:
        """Flight time [s] of frame ``counter``."""
        return self.t0_s + counter / self.fps

    def target_at(self, t_s: float) -> TargetState | None:
        """The drone as this camera sees it at ``t_s`` (None in blackbody mode)."""
        if self.scene.target is None or self.scene.blackbody_e is not None:
            return None
        if self.launch_s is not None and t_s < self.launch_s:
            return None  # not yet in the sky: the frames an operator takes a sky reference on
        truth = self.plan.truth(t_s)
        x, y = self.pointing.pixel_of(truth)
        return TargetState(
            x_px=x,
            y_px=y,
            total_e=self.scene.target.electrons_at(truth.range_m),
            size_px=self.pointing.size_px(self.scene.target.size_m, truth.range_m),
        )

    def __call__(self, counter: int) -> np.ndarray:
        t_s = self.time_of(counter)
        return self.renderer.render(counter, t_s, self.target_at(t_s))

    def truth(self, counter: int) -> FrameTruth | None:
        """Truth of frame ``counter`` without rendering it."""
        t_s = self.time_of(counter)
        return self.renderer.truth_for(counter, t_s, self.target_at(t_s))
