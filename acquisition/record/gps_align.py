"""Placing a drone's own flight log on a session's clock (``snrmon gps-import``).

A flight log's fixes carry UTC; a session's streams run on the host's monotonic clock, with
``/clock`` saying which UTC each stretch of it maps to (``docs/session-format.md``). A log fix
at UTC ``u`` lands at the host time ``t = monotonic_ns + (u - utc_ns)`` of the clock row whose
stretch ``[monotonic_ns, next row's monotonic_ns)`` holds that ``t``; a time before the first
row or in a gap between two re-anchorings takes the row it is nearest to (extrapolated).

When the session's UTC came from the host's own clock (no live GPS), it may be seconds off the
log's GPS time. Where the session has rangefinder readings, :func:`search_offset` finds the
offset ``d`` (s, added to the log's times) that best lays the log's slant ranges over the
rangefinder's: for each ``d`` on a grid, the GPS slant range is interpolated (linearly, in
time) at every valid rangefinder reading inside the log's span, and the cost is the RMS of
``gps - lrf - median(gps - lrf)``: the median takes out a constant bias (the rangefinder ranges
the drone's body, the GPS its antenna; a survey offset of the site), so only the timing is
fitted. ``d`` is applied only when it is identifiable and worth it: at least
``min_pairs`` pairs, the rangefinder's ranges spanning at least ``min_span_m`` (a hover alone
cannot time a log), the RMS at ``d`` at most ``1 - min_gain`` of the RMS at zero, and ``|d|``
at least ``min_offset_s`` (the caller passes the log's fix interval: a smaller offset is within
the log's resolution, and is more likely the rangefinder's own latency, some tens of ms at
9600 baud, than a clock error).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from snrmon.acquisition.geo.projection import Site, enu_of
from snrmon.acquisition.streams.timebase import utc_of_rows


def _clock_rows(clock: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ``/clock`` rows' (monotonic_ns, utc_ns), in monotonic order."""
    if len(clock) == 0:
        raise ValueError("the session has no /clock rows: its UTC cannot be mapped")
    order = np.argsort(clock["monotonic_ns"], kind="stable")
    return clock["monotonic_ns"][order].astype(np.int64), clock["utc_ns"][order].astype(np.int64)


def utc_to_host_ns(utc_ns: np.ndarray, clock: np.ndarray, *, chunk: int = 1024) -> np.ndarray:
    """Host monotonic ns of each UTC (ns) through the session's ``/clock`` rows."""
    utc_ns = np.asarray(utc_ns, dtype=np.int64)
    mono, utc = _clock_rows(clock)
    upper = np.append(mono[1:], np.iinfo(np.int64).max)
    out = np.empty(len(utc_ns), np.int64)
    for lo in range(0, len(utc_ns), chunk):  # (fixes x rows) pairs, a chunk of fixes at a time
        u = utc_ns[lo : lo + chunk]
        t = mono[None, :] + (u[:, None] - utc[None, :])  # t for every (fix, row) pair
        miss = np.maximum(mono[None, :] - t, 0) + np.maximum(t - upper[None, :] + 1, 0)
        inside = miss == 0  # the row is right when t falls in its stretch
        # The last row that holds t (a re-anchoring wins), else the nearest one.
        last = inside.shape[1] - 1 - np.argmax(inside[:, ::-1], axis=1)
        row = np.where(inside.any(axis=1), last, np.argmin(miss, axis=1))
        out[lo : lo + chunk] = t[np.arange(len(u)), row]
    return out


def host_to_utc_ns(t_host_ns: np.ndarray, clock: np.ndarray) -> np.ndarray:
    """UTC (ns) of host monotonic times through ``/clock``: the latest row at or before each
    time (the first row for a time before it), as ``docs/session-format.md`` states."""
    return utc_of_rows(clock, t_host_ns)


def slant_ranges_m(site: Site, lat_deg, lon_deg, alt_m) -> np.ndarray:
    """Straight-line distance (m) from the site to each geodetic point (vectorised)."""
    return np.linalg.norm(enu_of(site, lat_deg, lon_deg, alt_m), axis=-1)


@dataclass(frozen=True)
class OffsetSearch:
    """What the offset search found and did. ``offset_s`` is added to the log's times."""

    offset_s: float
    applied: bool
    reason: str
    searched_s: tuple[float, float]
    step_s: float
    pairs: int
    lrf_span_m: float
    rms_at_zero_m: float | None
    rms_at_best_m: float | None
    best_s: float | None

    def as_dict(self) -> dict:
        d = asdict(self)
        d["searched_s"] = list(self.searched_s)
        return d


def _cost(
    d_ns: float,
    t_gps: np.ndarray,
    r_gps: np.ndarray,
    t_lrf: np.ndarray,
    r_lrf: np.ndarray,
    min_pairs: int = 2,
) -> tuple[float, int]:
    t = t_lrf - d_ns  # the log's time at each reading
    inside = (t >= t_gps[0]) & (t <= t_gps[-1])
    if inside.sum() < max(min_pairs, 2):
        # An offset that leaves too few readings under the log fits them trivially well.
        return math.inf, int(inside.sum())
    diff = np.interp(t[inside], t_gps, r_gps) - r_lrf[inside]
    diff -= np.median(diff)
    return float(np.sqrt(np.mean(diff**2))), int(inside.sum())


def search_offset(
    t_gps_ns: np.ndarray,
    r_gps_m: np.ndarray,
    t_lrf_ns: np.ndarray,
    r_lrf_m: np.ndarray,
    *,
    max_offset_s: float = 10.0,
    step_s: float = 0.01,
    min_pairs: int = 20,
    min_span_m: float = 5.0,
    min_gain: float = 0.1,
    min_offset_s: float = 0.0,
) -> OffsetSearch:
    """The offset (s) that lays the GPS slant ranges over the rangefinder's (module docstring).

    ``t_gps_ns`` must be increasing (the log on the session clock, before any offset)."""
    if not (max_offset_s >= 0 and step_s > 0):
        raise ValueError(f"offset search needs max >= 0 and step > 0, got {max_offset_s}, {step_s}")
    t_gps, r_gps = np.asarray(t_gps_ns, float), np.asarray(r_gps_m, float)
    t_lrf, r_lrf = np.asarray(t_lrf_ns, float), np.asarray(r_lrf_m, float)
    cost0, pairs0 = _cost(0.0, t_gps, r_gps, t_lrf, r_lrf) if len(t_gps) > 1 else (math.inf, 0)
    span = float(np.ptp(r_lrf)) if len(r_lrf) else 0.0
    found = OffsetSearch(
        offset_s=0.0,
        applied=False,
        reason="",
        searched_s=(-max_offset_s, max_offset_s),
        step_s=step_s,
        pairs=pairs0,
        lrf_span_m=span,
        rms_at_zero_m=_finite(cost0),
        rms_at_best_m=None,
        best_s=None,
    )
    if len(t_lrf) < min_pairs or len(t_gps) < 2:
        why = f"too few readings ({len(t_lrf)} rangefinder, {len(t_gps)} GPS; {min_pairs} needed)"
        return replace(found, reason=why)
    grid = np.arange(-max_offset_s, max_offset_s + step_s / 2, step_s)
    costs = np.array([_cost(d * 1e9, t_gps, r_gps, t_lrf, r_lrf, min_pairs)[0] for d in grid])
    if not np.isfinite(costs).any():
        why = f"no offset within +/-{max_offset_s:g} s puts {min_pairs} rangefinder readings "
        return replace(found, reason=why + "under the log")
    i = int(np.argmin(costs))
    best, cost = float(round(grid[i], 6)), float(costs[i])
    pairs = _cost(best * 1e9, t_gps, r_gps, t_lrf, r_lrf)[1]
    found = replace(found, pairs=pairs, rms_at_best_m=_finite(cost), best_s=best)
    aligned = f"the best offset {best:+.3f} s"
    if span < min_span_m:
        why = f"the rangefinder's ranges span {span:.1f} m (< {min_span_m:g} m): a hover cannot "
        why += "time the log"
    elif math.isfinite(cost0) and cost > (1.0 - min_gain) * cost0:
        why = f"{aligned} improves the fit by less than {min_gain:.0%}: the log is taken as aligned"
    elif abs(best) < min_offset_s:
        why = f"{aligned} is within the log's {min_offset_s:g} s resolution: taken as aligned"
    else:
        return replace(found, offset_s=best, applied=True, reason="the best fit to the rangefinder")
    return replace(found, reason=why)


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None
