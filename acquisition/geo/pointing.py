"""Pointing calibration: the camera's azimuth, elevation and roll from (pixel, GPS) pairs.

The operator tracks the drone at close range, where it is bright and its GPS position is well
inside the field of view; each pair is the tracked pixel and the GPS position at that frame.
Least squares (``scipy.optimize.least_squares``, plain squares) over
(az, el, roll) minimises the pixel distance between each tracked pixel and the projection of its
GPS position (conventions of :mod:`snrmon.acquisition.geo.projection`). The residual is reported in
pixels, per
pair and as RMS and maximum, so the operator sees at once whether the fit can cue the search.

Three or more pairs are required: two already determine the three angles, the third is the check
that gives the residual meaning. Pairs spread across the image pin the roll down; pairs bunched
in one spot leave it loose (the residual stays small while roll is poorly known).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from snrmon.acquisition.geo.projection import CameraIntrinsics, Pointing, Site, enu_of, project_enu

# Pixel residual given to a pair that lands behind the camera during the search: large and
# smooth enough that the optimiser turns back toward the front.
_BEHIND_PENALTY_PX = 1e4


@dataclass(frozen=True, slots=True)
class PointingFit:
    """The fitted pointing (degrees) and how well it explains the pairs (pixels)."""

    az_deg: float
    el_deg: float
    roll_deg: float
    residual_px_rms: float
    residual_px_max: float
    residuals_px: tuple[float, ...] = ()
    n_pairs: int = 0

    @property
    def pointing(self) -> Pointing:
        return Pointing(self.az_deg, self.el_deg, self.roll_deg)


def _residuals(
    params: np.ndarray, enu: np.ndarray, xy: np.ndarray, cam: CameraIntrinsics
) -> np.ndarray:
    az, el, roll = params
    x, y, depth = project_enu(enu, az, el, roll, cam)
    res = np.stack([x - xy[:, 0], y - xy[:, 1]], axis=1)
    behind = ~(depth > 0)
    if behind.any():
        res[behind] = _BEHIND_PENALTY_PX * (1.0 - depth[behind, None])
    return res.ravel()


def _initial_guesses(enu: np.ndarray, initial: Pointing | None) -> list[np.ndarray]:
    if initial is not None:
        return [np.radians([initial.az_deg, initial.el_deg, initial.roll_deg])]
    # The mean line of sight to the pairs: the axis is near it when the pairs sit around the
    # image centre. Roll is unknown: try four quadrants and keep the best fit.
    unit = enu / np.linalg.norm(enu, axis=1, keepdims=True)
    d = unit.mean(axis=0)
    az = math.atan2(d[0], d[1])
    el = math.atan2(d[2], math.hypot(d[0], d[1]))
    return [np.array([az, el, r]) for r in (0.0, math.pi / 2, math.pi, -math.pi / 2)]


def _wrap_deg(angle_deg: float) -> float:
    """(-180, 180]."""
    a = math.fmod(angle_deg, 360.0)
    if a <= -180.0:
        a += 360.0
    elif a > 180.0:
        a -= 360.0
    return a


def calibrate_pointing(
    pairs: Sequence[tuple[float, float, float, float, float]],
    site: Site,
    intrinsics: CameraIntrinsics,
    initial: Pointing | None = None,
) -> PointingFit:
    """Fit (az, el, roll) to pairs ``(x_px, y_px, lat_deg, lon_deg, alt_m)`` by least squares.

    ``initial``: a starting pointing (degrees); None starts from the mean line of sight to the
    pairs with four roll quadrants. Fewer than three distinct pairs, non-finite values, a pair at
    the site itself, or pairs all on one line of sight (within a pixel) are a ValueError.
    Azimuth is returned in [0, 360), roll in (-180, 180].
    """
    rows = [tuple(p) for p in pairs]
    if len(rows) < 3:
        raise ValueError(
            f"pointing calibration needs at least 3 (pixel, GPS) pairs, got {len(rows)}"
        )
    for i, row in enumerate(rows):
        if len(row) != 5 or not all(math.isfinite(float(v)) for v in row):
            raise ValueError(
                f"pair {i} must be five finite numbers (x_px, y_px, lat, lon, alt), got {row}"
            )
    arr = np.asarray(rows, float)
    xy = arr[:, :2]
    enu = enu_of(site, arr[:, 2], arr[:, 3], arr[:, 4])
    dist = np.linalg.norm(enu, axis=1)
    if (dist < 1e-3).any():
        raise ValueError(f"pair {int(np.argmin(dist))} is at the camera site; it has no direction")
    # Three unknowns (az, el, roll): a repeated pair adds no equation, and lines of sight that
    # are all one (within a pixel) leave the roll about it free, so either fit has a residual
    # of zero that says nothing.
    distinct = len(np.unique(arr, axis=0))
    if distinct < 3:
        raise ValueError(
            f"pointing calibration needs at least 3 distinct (pixel, GPS) pairs for azimuth, "
            f"elevation and roll, got {distinct} distinct of {len(rows)}"
        )
    unit = enu / dist[:, None]
    spread_px = float(np.arccos(np.clip(unit @ unit[0], -1.0, 1.0)).max()) / (
        intrinsics.pitch_m / intrinsics.focal_length_m
    )
    if spread_px < 1.0:
        raise ValueError(
            f"the {distinct} distinct pairs' GPS positions lie on one line of sight (within "
            f"{spread_px:.2g} px of each other): they cannot fix the roll; spread them over the "
            "field of view"
        )

    best = None
    for x0 in _initial_guesses(enu, initial):
        sol = least_squares(_residuals, x0, args=(enu, xy, intrinsics), method="lm", xtol=1e-12)
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None
    az, el, roll = best.x
    # Elevation beyond +-90 deg is the same axis reached the other way round: fold it back.
    el_deg = math.degrees(math.atan2(math.sin(el), abs(math.cos(el))))
    az_deg = math.degrees(az)
    roll_deg = math.degrees(roll)
    if math.cos(el) < 0:
        az_deg += 180.0
        roll_deg += 180.0
    az_deg %= 360.0
    roll_deg = _wrap_deg(roll_deg)
    res = _residuals(np.radians([az_deg, el_deg, roll_deg]), enu, xy, intrinsics).reshape(-1, 2)
    per_pair = np.hypot(res[:, 0], res[:, 1])
    return PointingFit(
        az_deg=float(az_deg),
        el_deg=float(el_deg),
        roll_deg=float(roll_deg),
        residual_px_rms=float(np.sqrt(np.mean(per_pair**2))),
        residual_px_max=float(per_pair.max()),
        residuals_px=tuple(float(v) for v in per_pair),
        n_pairs=len(rows),
    )
