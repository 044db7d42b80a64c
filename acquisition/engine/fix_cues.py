"""What a GPS fix does to the cameras: projected into each pointed camera, it cues that camera's
tracker to reacquire the drone near it (paper section 4), or is only shown on its display.
"""

from __future__ import annotations

from collections.abc import Mapping

from snrmon.acquisition.config import SessionConfig
from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import Cue
from snrmon.acquisition.geo.gps_cue import GpsProjector
from snrmon.drivers.gps.fix import GpsFix


class FixCues:
    """Each fix projected into the config's pointed cameras: a :class:`Cue` to each camera's
    tracker (``cue``), else shown only (``show``; off for a batch replay, which has no
    display)."""

    def __init__(self, config: SessionConfig, *, cue: bool, show: bool) -> None:
        self.projector = GpsProjector(config)
        self.cue = cue
        # A batch replay that applies the recorded cues has no display to draw the fix in.
        self.show = show or cue

    def apply(self, fix: GpsFix, cameras: Mapping[str, CameraEngine]) -> None:
        """``fix`` into every camera of ``cameras`` it projects into."""
        if not self.show:
            return
        for name, (x, y) in self.projector.pixels(fix).items():
            camera = cameras.get(name)  # a replay of some of the cameras only
            if camera is None:
                continue
            if self.cue:
                camera.post(Cue(x, y))
            else:
                camera.show_gps(x, y)
