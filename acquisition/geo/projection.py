"""GPS position -> camera pixel: the camera site, its pointing, its intrinsics, the projection.

Owns the geometry that lets the drone's GPS fix cue the search when the track is lost (paper
section 7: the drone was reacquired by its GPS position) and that gives the GPS slant range of
each stop.

Geodesy is pymap3d's ``geodetic2enu`` (WGS-84): the target's east/north/up offset from the camera
site. The site's and the target's altitudes must be in the same vertical datum (both above mean
sea level, like NMEA GGA, or both above the ellipsoid); over the few hundred metres of a flight the
geoid separation changes by millimetres, so either choice gives the same local geometry.

Rotation convention (angles in degrees at the edges, radians inside):

- azimuth ``az``: of the optical axis, clockwise from true north (0 = north, 90 = east);
- elevation ``el``: of the optical axis above the local horizontal (east-north plane);
- roll ``roll``: rotation of the camera about its optical axis, positive when the camera turns
  clockwise as seen from behind it, looking out along the axis (its right side dips: "right wing
  down"). The scene then appears turned counter-clockwise on the screen by the same angle.

With roll 0 the image's right (+x) is horizontal, ``r0 = (cos az, -sin az, 0)`` in ENU, the
optical axis is ``f = (cos el sin az, cos el cos az, sin el)`` and the image's up is
``u0 = r0 x f``. Roll turns the image axes about ``f``: ``r = cos(roll) r0 - sin(roll) u0``,
``u = sin(roll) r0 + cos(roll) u0``. Camera coordinates (x right, y down, z forward) form a
right-handed frame, as in OpenCV.

Pinhole projection (x = column, y = row down, pixel centres at integers, optical axis at
``((W-1)/2, (H-1)/2)``): ``x = cx + (f_m / pitch_m) * (p.r) / (p.f)``,
``y = cy - (f_m / pitch_m) * (p.u) / (p.f)`` for the ENU offset ``p``. No lens distortion.
A point at or behind the camera's focal plane (``p.f <= 0``) has no image: x and y are NaN.
``in_view`` is true when the point is in front and inside the array's outer pixel edges
(``-0.5 <= x <= W - 0.5`` and likewise for y).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymap3d

from snrmon.drivers.gps.fix import GpsFix


@dataclass(frozen=True, slots=True)
class Site:
    """The camera position: WGS-84 latitude and longitude (degrees), altitude (metres; same
    vertical datum as the GPS altitudes it is compared with)."""

    lat_deg: float
    lon_deg: float
    alt_m: float

    def __post_init__(self) -> None:
        _check_finite("site", (self.lat_deg, self.lon_deg, self.alt_m))
        if not -90.0 <= self.lat_deg <= 90.0:
            raise ValueError(f"site latitude must be in [-90, 90] degrees, got {self.lat_deg}")
        if not -180.0 <= self.lon_deg <= 360.0:
            raise ValueError(f"site longitude must be in [-180, 360] degrees, got {self.lon_deg}")


@dataclass(frozen=True, slots=True)
class Pointing:
    """Where the optical axis points (degrees; see the module docstring for the convention)."""

    az_deg: float
    el_deg: float
    roll_deg: float = 0.0

    def __post_init__(self) -> None:
        _check_finite("pointing", (self.az_deg, self.el_deg, self.roll_deg))
        if not -90.0 < self.el_deg < 90.0:
            raise ValueError(f"pointing elevation must be in (-90, 90) degrees, got {self.el_deg}")


@dataclass(frozen=True, slots=True)
class CameraIntrinsics:
    """Pinhole intrinsics: focal length and pixel pitch in metres, array format in pixels."""

    focal_length_m: float
    pitch_m: float
    width_px: int
    height_px: int

    def __post_init__(self) -> None:
        for name in ("focal_length_m", "pitch_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"camera {name} must be a positive number, got {value}")
        for name in ("width_px", "height_px"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"camera {name} must be a positive integer, got {value}")

    @classmethod
    def from_sensor(cls, sensor: Any) -> CameraIntrinsics:
        """From a model sensor (attributes ``focal_length_m``, ``pitch_um``, ``width_px``,
        ``height_px``, as in :mod:`snrmon.model.presets`)."""
        return cls(
            float(sensor.focal_length_m),
            float(sensor.pitch_um) * 1e-6,
            int(sensor.width_px),
            int(sensor.height_px),
        )

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (f / pitch): the inverse of the IFOV in radians."""
        return self.focal_length_m / self.pitch_m

    @property
    def centre_xy(self) -> tuple[float, float]:
        """Where the optical axis lands: ((W-1)/2, (H-1)/2)."""
        return (self.width_px - 1) / 2.0, (self.height_px - 1) / 2.0


@dataclass(frozen=True, slots=True)
class PixelProjection:
    """A geodetic point in a camera: x (column), y (row), slant range (m), whether it is seen.
    x and y are NaN when the point is at or behind the camera's focal plane."""

    x: float
    y: float
    range_m: float
    in_view: bool


def _check_finite(what: str, values: tuple[float, ...]) -> None:
    if not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
        raise ValueError(f"{what} must be finite numbers, got {values}")


def camera_axes(az_rad: float, el_rad: float, roll_rad: float) -> np.ndarray:
    """Rows (right, up, forward) of the camera in ENU, unit vectors (module docstring)."""
    ca, sa = math.cos(az_rad), math.sin(az_rad)
    ce, se = math.cos(el_rad), math.sin(el_rad)
    fwd = np.array([ce * sa, ce * ca, se])
    r0 = np.array([ca, -sa, 0.0])
    u0 = np.cross(r0, fwd)
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    return np.stack([cr * r0 - sr * u0, sr * r0 + cr * u0, fwd])


def enu_of(site: Site, lat_deg, lon_deg, alt_m) -> np.ndarray:
    """East, north, up offsets (m) of geodetic points from the site, shape (..., 3):
    ``pymap3d.geodetic2enu``'s own steps (both points to ECEF, the difference rotated into the
    site's ENU), the site's ECEF computed once (every GPS fix is projected: 10 a second)."""
    x1, y1, z1 = pymap3d.geodetic2ecef(lat_deg, lon_deg, alt_m, deg=True)
    x2, y2, z2 = _site_ecef(site)
    e, n, u = pymap3d.uvw2enu(x1 - x2, y1 - y2, z1 - z2, site.lat_deg, site.lon_deg, deg=True)
    return np.stack([np.asarray(e, float), np.asarray(n, float), np.asarray(u, float)], axis=-1)


@functools.lru_cache(maxsize=16)
def _site_ecef(site: Site) -> tuple:
    return pymap3d.geodetic2ecef(site.lat_deg, site.lon_deg, site.alt_m, deg=True)


def project_enu(
    enu: np.ndarray, az_rad: float, el_rad: float, roll_rad: float, cam: CameraIntrinsics
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, depth) of ENU offsets (..., 3) in the camera; x, y NaN where depth <= 0."""
    axes = camera_axes(az_rad, el_rad, roll_rad)
    c = np.asarray(enu, float) @ axes.T
    depth = c[..., 2]
    cx, cy = cam.centre_xy
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = depth > 0
        x = np.where(ok, cx + cam.focal_px * c[..., 0] / depth, np.nan)
        y = np.where(ok, cy - cam.focal_px * c[..., 1] / depth, np.nan)
    return x, y, depth


def in_view_of(x: float, y: float, cam: CameraIntrinsics) -> bool:
    """True when (x, y) is on the array (inside its outer pixel edges); False for NaN."""
    return bool(-0.5 <= x <= cam.width_px - 0.5 and -0.5 <= y <= cam.height_px - 0.5)


def project_to_pixel(
    site: Site,
    pointing: Pointing,
    intrinsics: CameraIntrinsics,
    lat_deg: float,
    lon_deg: float,
    alt_m: float,
) -> PixelProjection:
    """Where the geodetic point (lat, lon, alt) lands in the camera, and its slant range."""
    _check_finite("target", (lat_deg, lon_deg, alt_m))
    enu = enu_of(site, lat_deg, lon_deg, alt_m)
    x, y, _ = project_enu(
        enu,
        math.radians(pointing.az_deg),
        math.radians(pointing.el_deg),
        math.radians(pointing.roll_deg),
        intrinsics,
    )
    xf, yf = float(x), float(y)
    return PixelProjection(xf, yf, float(np.linalg.norm(enu)), in_view_of(xf, yf, intrinsics))


def slant_range_m(site: Site, lat_deg: float, lon_deg: float, alt_m: float) -> float:
    """Straight-line distance (m) from the site to a geodetic point."""
    _check_finite("target", (lat_deg, lon_deg, alt_m))
    return float(np.linalg.norm(enu_of(site, lat_deg, lon_deg, alt_m)))


def fix_position(fix: GpsFix) -> tuple[float, float, float] | None:
    """(lat, lon, alt above MSL) of a fix; None without a fix or without an MSL altitude
    (an ellipsoidal height is not substituted: it differs by the geoid separation, tens of m)."""
    if not fix.has_fix or fix.alt_msl_m is None:
        return None
    return float(fix.lat_deg), float(fix.lon_deg), float(fix.alt_msl_m)  # type: ignore[arg-type]


def gps_slant_range_m(fix: GpsFix, site: Site) -> float | None:
    """GPS slant range (m) of a fix from a site whose altitude is above MSL; None when the fix
    has no position or no MSL altitude."""
    pos = fix_position(fix)
    return None if pos is None else slant_range_m(site, *pos)


def parse_triple(text: str, what: str) -> tuple[float, float, float]:
    """ "A,B,C" -> three finite floats; anything else is a ValueError naming ``what``."""
    parts = text.split(",")
    try:
        if len(parts) != 3:
            raise ValueError
        values = tuple(float(p) for p in parts)
        if not all(math.isfinite(v) for v in values):
            raise ValueError
    except ValueError:
        raise ValueError(f"{what} must be three numbers A,B,C, got {text!r}") from None
    return values  # type: ignore[return-value]
