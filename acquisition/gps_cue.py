"""The drone's GPS fix as each pointed camera sees it, live or from a recording (paper section 4).

The paper's operators found a lost drone again from its GPS position; the console does the same:
each fix is projected into every camera whose pointing (azimuth, elevation, roll) is configured,
through the intrinsics of its sensor preset (:mod:`acquisition.geo`). The result cues the
tracker and draws the GPS cross. :func:`fix_from_record` turns a recorded GPS row back into the
:class:`drivers.gps.fix.GpsFix` it was written from, so a replay shows the same fix and cross.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta

import numpy as np

from acquisition.geo import CameraIntrinsics, fix_position, project_to_pixel
from acquisition.session_config import SessionConfig
from drivers.gps.fix import GpsFix


class GpsProjector:
    """Projects a fix into every camera of ``config`` that has a pointing."""

    def __init__(self, config: SessionConfig) -> None:
        self.site = config.site
        self._cameras = []
        for cam in config.cameras:
            if cam.pointing is None:
                continue
            from model.presets import load_sensor  # focal length, pitch and format

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


def _opt(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def fix_from_record(row: np.void) -> GpsFix:
    """The :class:`GpsFix` a recorded GPS row (``docs/session-format.md``, /gps) came from."""
    fix_utc_ns = int(row["fix_utc_ns"])
    utc = None
    if fix_utc_ns >= 0:
        utc = datetime(1970, 1, 1, tzinfo=UTC) + timedelta(microseconds=fix_utc_ns // 1000)
    sats = int(row["sats"])
    raw = bytes(row["raw"]).decode("utf-8", errors="replace")
    return GpsFix(
        t_host_ns=int(row["t_host_ns"]),
        utc=utc,
        lat_deg=_opt(row["lat_deg"]),
        lon_deg=_opt(row["lon_deg"]),
        alt_msl_m=_opt(row["alt_msl_m"]),
        alt_ellipsoid_m=_opt(row["alt_ellipsoid_m"]),
        fix_quality=int(row["fix_quality"]),
        sats=None if sats < 0 else sats,
        hdop=_opt(row["hdop"]),
        raw=raw,
    )
