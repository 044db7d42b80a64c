"""The drone's GPS fix as each pointed camera sees it, live or from a recording (paper section 4).

The paper's operators found a lost drone again from its GPS position; the console does the same:
each fix is projected into every camera whose pointing (azimuth, elevation, roll) is configured,
through the intrinsics of its sensor preset (:mod:`snrmon.acquisition.geo.projection`). The result
cues the tracker and draws the GPS cross.
"""

from __future__ import annotations

from snrmon.acquisition.config import SessionConfig
from snrmon.acquisition.geo.projection import CameraIntrinsics, fix_position, project_to_pixel
from snrmon.drivers.gps.fix import GpsFix


class GpsProjector:
    """Projects a fix into every camera of ``config`` that has a pointing."""

    def __init__(self, config: SessionConfig) -> None:
        self.site = config.site
        self._cameras = []
        for cam in config.cameras:
            if cam.pointing is None:
                continue
            from snrmon.model.presets import load_sensor  # focal length, pitch and format

            intrinsics = CameraIntrinsics.from_sensor(load_sensor(cam.sensor))
            self._cameras.append((cam.name, cam.pointing, intrinsics))

    def pixels(self, fix: GpsFix) -> dict[str, tuple[float, float]]:
        """{camera: (x, y)} where the fix falls in view (x = column, y = row, pixel centres
        on integers); a camera that does not see it, or a fix without position, is left out."""
        pos = fix_position(fix)
        if pos is None or self.site is None:
            return {}
        out = {}
        for name, pointing, intrinsics in self._cameras:
            p = project_to_pixel(self.site, pointing, intrinsics, *pos)
            if p.in_view:
                out[name] = (p.x, p.y)
        return out
