"""Example data made with the product's own code, for the API's examples, the tutorials and
the tests: a short simulated session recorded with the real recorder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d

from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading

T0_NS = 10**12
SITE = {"lat_deg": 32.38, "lon_deg": -106.48, "alt_m": 1200.0}
SHAPE = (40, 56)
SPOT_XY = (30, 20)
SKY_DN = 1000.0
NOISE_DN = 5.0


@dataclass(frozen=True)
class ExampleSession:
    """What :func:`example_session` put in its file: the planned stops, the cameras, the frame
    times and every frame's pixels."""

    path: Path
    ranges_m: tuple[float, ...]
    cameras: tuple[str, ...]
    fps: float
    frame_t_ns: np.ndarray
    frames: dict[str, np.ndarray]


def _range_at(t_s: np.ndarray, plan: list[tuple[float, float, float]]) -> np.ndarray:
    """Planned range at times t: hover segments (t0, t1, range), linear in between."""
    knots_t, knots_r = [], []
    for t0, t1, r in plan:
        knots_t += [t0, t1]
        knots_r += [r, r]
    return np.interp(t_s, knots_t, knots_r)


def example_session(
    path: str | Path,
    *,
    ranges_m: tuple[float, ...] = (120.0, 240.0),
    hover_s: float = 8.0,
    transit_s: float = 3.0,
    fps: float = 20.0,
    amplitude_dn: float = 200.0,
    reference_range_m: float = 120.0,
    cameras: tuple[str, ...] = ("mwir", "lwir"),
    target: str = "uav1",
    seed: int = 11,
) -> ExampleSession:
    """Record a simulated flight into ``path`` with the real recorder and return what was put in
    it: each camera sees one Gaussian spot (sigma 0.8 px) on seeded sky noise (1000 DN, sigma
    5 DN) at column 30, row 20 of a 56 x 40 frame, clicked at its first frame (a ``roi_set``
    event); the drone hovers ``hover_s`` at each range of ``ranges_m`` with straight transits
    between, the rangefinder reads at 2 Hz and the GPS at 10 Hz (due north of the site, at its
    altitude, so the GPS slant range is the planned range). The spot's amplitude falls as
    (``reference_range_m`` / range)^2, so the SNR falls with range like a point target's.
    The file holds frames and readings, not measurements: a replay measures them.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from snrmon.examples import example_session
    >>> made = example_session(pathlib.Path(tempfile.mkdtemp()) / "s.h5", hover_s=2.0)
    >>> made.cameras, made.ranges_m, made.frames["mwir"].shape
    (('mwir', 'lwir'), (120.0, 240.0), (200, 40, 56))
    """
    path = Path(path)
    rng = np.random.default_rng(seed)
    plan, t = [], 0.0
    for r in ranges_m:
        plan.append((t, t + hover_s, r))
        t += hover_s + transit_s
    # The flight goes on 3 s past the last stop so the detector sees that stop end.
    plan.append((t, t + 1.0, ranges_m[-1] + 60.0))
    total_s = t
    config = {
        "session": {
            "target": target,
            "site": dict(SITE),
            "cameras": {c: {"source": "shm", "sensor": c} for c in cameras},
        }
    }
    rec = SessionRecorder(
        path,
        config=config,
        cameras=dict.fromkeys(cameras, SHAPE),
        flush_interval_s=0.2,
        fsync=False,
    )
    n = int(total_s * fps)
    t_ns = T0_NS + np.rint(np.arange(n) / fps * 1e9).astype(np.int64)
    frame_ranges = _range_at((t_ns - T0_NS) / 1e9, plan)
    yy, xx = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]]
    spot = np.exp(-((xx - SPOT_XY[0]) ** 2 + (yy - SPOT_XY[1]) ** 2) / (2 * 0.8**2))
    frames: dict[str, np.ndarray] = {}
    for cam in cameras:
        rec.add_event(
            "roi_set",
            camera=cam,
            payload={"x": SPOT_XY[0], "y": SPOT_XY[1]},
            t_host_ns=int(t_ns[0]),
        )
        amp = amplitude_dn * (reference_range_m / frame_ranges) ** 2
        stack = rng.normal(SKY_DN, NOISE_DN, (n, *SHAPE)) + amp[:, None, None] * spot
        stack = np.rint(stack).astype(np.uint16)
        frames[cam] = stack
        for i in range(n):
            rec.add_frame(cam, Frame(stack[i], cam, i, int(t_ns[i])))
    for tr in np.arange(0.0, total_s, 0.5):
        r = float(_range_at(np.array([tr]), plan)[0]) + rng.normal(0.0, 0.1)
        rec.add_range(RangeReading(T0_NS + int(tr * 1e9), r, raw=f"{r:.1f}"))
    for tg in np.arange(0.0, total_s, 0.1):
        r = float(_range_at(np.array([tg]), plan)[0]) + rng.normal(0.0, 0.3)
        lat, lon, alt = pymap3d.enu2geodetic(
            0.0, r, 0.0, SITE["lat_deg"], SITE["lon_deg"], SITE["alt_m"]
        )
        rec.add_gps(
            GpsFix(
                T0_NS + int(tg * 1e9), None, float(lat), float(lon), float(alt), None, 1, 9, 0.8, ""
            )
        )
    rec.stop()
    return ExampleSession(path, tuple(ranges_m), tuple(cameras), fps, t_ns, frames)
