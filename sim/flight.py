"""The paper's collection flight (section 4): out along the line of sight, hovering at stops.

Owns the ground truth of the drone's position versus time: the site (lat, lon, alt), the line of
sight (azimuth, elevation) from the cameras toward the clear-sky patch, the planned stops
(37, 126, 199, 336, 393, 451, 508 m by default), transit at a set speed, hover for a set time,
and a small seeded wind drift around the nominal point (per axis a slow sinusoidal sway and a
triangle wave of steady drifts reversed by the position hold, seeded phases: a hovering drone
in gusts). From it come the callables that drive the GPS
(:meth:`FlightPlan.position`) and rangefinder (:meth:`FlightPlan.range_m`) simulators, and, with
:class:`CameraPointing`, the drone's sub-pixel position in each camera (pinhole projection of the
offset from the optical axis, divided by the sensor's IFOV).

Geodesy is pymap3d's ``enu2geodetic`` (WGS-84). Angles are degrees in the configuration and
truth records (the edges), radians inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d

PAPER_STOPS_M = (37.0, 126.0, 199.0, 336.0, 393.0, 451.0, 508.0)


@dataclass(frozen=True)
class Site:
    """The camera position (WGS-84)."""

    lat_deg: float = 32.3800
    lon_deg: float = -106.4800
    alt_m: float = 1200.0


@dataclass(frozen=True)
class FlightConfig:
    """Every number of the flight; see the module docstring."""

    site: Site = Site()
    azimuth_deg: float = 40.0  # line of sight, clockwise from north
    elevation_deg: float = 8.0  # line of sight above the horizon
    stops_m: tuple[float, ...] = PAPER_STOPS_M
    speed_mps: float = 5.0  # transit speed along the line of sight
    hover_s: float = 6.0  # >= 100 frames at 30 fps plus margin
    start_range_m: float = 10.0  # where the drone starts (take-off done)
    drift_amplitude_m: tuple[float, float, float] = (0.6, 0.15, 0.4)  # right, along, up
    drift_period_s: tuple[float, float] = (5.3, 1.7)  # slow sway, position-hold corrections
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.stops_m or any(not r > 0 for r in self.stops_m):
            raise ValueError(f"flight stops must be > 0 m, got {self.stops_m}")
        if not self.speed_mps > 0:
            raise ValueError(f"transit speed must be > 0 m/s, got {self.speed_mps}")
        if not self.hover_s > 0:
            raise ValueError(f"hover time must be > 0 s, got {self.hover_s}")
        if not self.start_range_m > 0:
            raise ValueError(f"start range must be > 0 m, got {self.start_range_m}")
        if not -90.0 < self.elevation_deg < 90.0:
            raise ValueError(f"elevation must be in (-90, 90) deg, got {self.elevation_deg}")


@dataclass(frozen=True)
class FlightTruth:
    """Where the drone is at ``t_s`` (truth; no sensor noise)."""

    t_s: float
    range_m: float  # slant range camera -> drone, drift included
    nominal_range_m: float  # along the line of sight, without drift
    lat_deg: float
    lon_deg: float
    alt_m: float
    east_m: float
    north_m: float
    up_m: float
    right_m: float  # offset from the optical axis, to the right in the image
    above_m: float  # offset from the optical axis, up in the image
    along_m: float  # distance along the optical axis
    stop_index: int | None  # index into stops_m while hovering, else None
    planned_range_m: float | None


@dataclass(frozen=True)
class _Segment:
    t0: float
    t1: float
    r0: float
    r1: float
    stop_index: int | None


class FlightPlan:
    """Timeline of the flight; picklable, cheap to query at any time."""

    def __init__(self, config: FlightConfig = FlightConfig()):
        self.config = config
        az = math.radians(config.azimuth_deg)
        el = math.radians(config.elevation_deg)
        self._los = np.array(
            [math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)]
        )
        self._right = np.array([math.cos(az), -math.sin(az), 0.0])
        self._up = np.cross(self._right, self._los)
        rng = np.random.default_rng([config.seed, 0xF11])
        self._drift_phase = rng.uniform(0.0, 2.0 * math.pi, size=(3, 2))
        # Slightly different periods per axis so the path is not a closed Lissajous figure.
        self._drift_period = np.asarray(config.drift_period_s) * rng.uniform(0.85, 1.15, (3, 2))
        segments = []
        t, r = 0.0, config.start_range_m
        for i, stop in enumerate(config.stops_m):
            dt = abs(stop - r) / config.speed_mps
            segments.append(_Segment(t, t + dt, r, stop, None))
            t += dt
            segments.append(_Segment(t, t + config.hover_s, stop, stop, i))
            t += config.hover_s
            r = stop
        self._segments = tuple(segments)

    @property
    def duration_s(self) -> float:
        """Time at the end of the last hover; after it the drone keeps hovering there."""
        return self._segments[-1].t1

    def stop_windows(self) -> list[tuple[float, float, float]]:
        """(t_start_s, t_end_s, planned_range_m) of every hover."""
        return [(s.t0, s.t1, s.r0) for s in self._segments if s.stop_index is not None]

    def _nominal(self, t_s: float) -> tuple[float, int | None]:
        if t_s <= 0.0:
            return self.config.start_range_m, None
        for s in self._segments:
            if t_s < s.t1:
                frac = (t_s - s.t0) / (s.t1 - s.t0) if s.t1 > s.t0 else 1.0
                return s.r0 + frac * (s.r1 - s.r0), s.stop_index
        last = self._segments[-1]
        return last.r1, last.stop_index

    def drift_m(self, t_s: float) -> np.ndarray:
        """Wind drift (right, along, up) [m] around the nominal point."""
        amp = np.asarray(self.config.drift_amplitude_m, float)
        arg = 2.0 * math.pi * t_s / self._drift_period + self._drift_phase
        # A slow sinusoidal sway and, of equal weight, the position hold's corrections: steady
        # drifts reversed (a triangle wave). A steady sweep visits every sub-pixel phase
        # equally, as the model's average PVF assumes (paper section 7); a sinusoid dwells at
        # its turning points and biased a sharp LWIR PSF's 100-frame mean by up to 12 %.
        sway = np.sin(arg[:, 0])
        hold = (2.0 / math.pi) * np.arcsin(np.sin(arg[:, 1]))
        return amp * 0.5 * (sway + hold)

    def truth(self, t_s: float) -> FlightTruth:
        if not math.isfinite(t_s):
            raise ValueError(f"flight time must be finite, got {t_s}")
        nominal, stop = self._nominal(t_s)
        right, along_d, above = self.drift_m(t_s)
        along = nominal + along_d
        enu = along * self._los + right * self._right + above * self._up
        site = self.config.site
        lat, lon, alt = pymap3d.enu2geodetic(
            enu[0], enu[1], enu[2], site.lat_deg, site.lon_deg, site.alt_m
        )
        return FlightTruth(
            t_s=float(t_s),
            range_m=float(np.linalg.norm(enu)),
            nominal_range_m=float(nominal),
            lat_deg=float(lat),
            lon_deg=float(lon),
            alt_m=float(alt),
            east_m=float(enu[0]),
            north_m=float(enu[1]),
            up_m=float(enu[2]),
            right_m=float(right),
            above_m=float(above),
            along_m=float(along),
            stop_index=stop,
            planned_range_m=None if stop is None else float(self.config.stops_m[stop]),
        )

    def position(self, t_s: float) -> tuple[float, float, float]:
        """(lat_deg, lon_deg, alt_m) at ``t_s``: the GPS simulator's truth."""
        tr = self.truth(t_s)
        return tr.lat_deg, tr.lon_deg, tr.alt_m

    def range_m(self, t_s: float) -> float:
        """Slant range [m] at ``t_s``: the rangefinder simulator's truth."""
        return self.truth(t_s).range_m


@dataclass(frozen=True)
class CameraPointing:
    """A camera whose optical axis points along the flight's line of sight.

    ``boresight_offset_px`` is where the line of sight lands relative to the image centre
    (x right, y down): two cameras on one mount are never perfectly co-aligned.
    """

    ifov_rad: float
    width_px: int
    height_px: int
    boresight_offset_px: tuple[float, float] = (0.0, 0.0)

    def pixel_of(self, truth: FlightTruth) -> tuple[float, float]:
        """(x, y) sub-pixel image position of the drone (pixel centres at integers)."""
        if truth.along_m <= 0:
            raise ValueError(f"drone is behind the camera (along = {truth.along_m} m)")
        cx = (self.width_px - 1) / 2.0 + self.boresight_offset_px[0]
        cy = (self.height_px - 1) / 2.0 + self.boresight_offset_px[1]
        return (
            cx + truth.right_m / truth.along_m / self.ifov_rad,
            cy - truth.above_m / truth.along_m / self.ifov_rad,
        )

    def size_px(self, size_m: float, range_m: float) -> float:
        """Characteristic dimension at range, in pixels (small-angle)."""
        return size_m / (range_m * self.ifov_rad)
