"""The simulated collection day's twin cameras, their calibration at the start of the day, and
the PSF measured from the flight at its end.

* :func:`camera_feeds`: each camera's renderer is the digital twin of :mod:`snrmon.sim.twin` (its
  own optics and the drone's outline; the scenario's sky and air), not the model's PSF.
* :func:`calibrate_cameras`: as a field day starts, each camera looks into an extended
  blackbody at two temperatures; the frames go through the camera's very fixed-pattern gain and
  offset (the same renderer, the same seed) and are accumulated into the per-pixel mean and
  temporal std, and ``acquisition.calibrate.calibration.calibrate_means`` makes the two-point
  calibration, saved as a file the session configuration names (so the session applies it,
  follows the sky temperature with it and records it).
* :class:`CropLog`: while flying, the 13 x 13 pixels around every valid measured peak
  (non-uniformity corrected), so that a stop's frames can give the PSF
  (``acquisition.calibrate.psf_estimate``) without a recording.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import replace
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

BLACKBODY_K = (273.15, 318.15)
"""The two blackbody temperatures of the day's calibration (0 and 45 C: around the sky and
the drone)."""
BLACKBODY_FRAMES = 128


def camera_feeds(opts, flight_config, preroll_s: float) -> dict:
    """{camera: (sensor preset, :class:`snrmon.sim.feed.FlightCameraFeed`)}: each camera's twin."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.sim.feed import FlightCameraFeed
    from snrmon.sim.twin import twin_scene_config

    target = load_target(opts.target)
    out = {}
    for i, cam in enumerate(opts.cameras):
        sensor = load_sensor(cam)
        extra = {}
        if opts.window_px is not None:
            extra = {"width_px": int(opts.window_px[0]), "height_px": int(opts.window_px[1])}
        scene = twin_scene_config(sensor, target, opts.scenario, **extra)
        if not opts.fpn:
            scene = replace(scene, fpn_enabled=False)
        # two cameras on a mount are never co-aligned to a fraction of a pixel: the sight line
        # lands at a seeded sub-pixel offset, not always on a pixel corner
        offset = np.random.default_rng([opts.seed, i, 0xB0]).uniform(-0.5, 0.5, 2)
        feed = FlightCameraFeed(
            scene,
            flight_config,
            fps=sensor.fps,
            seed=opts.seed + i,
            t0_s=-preroll_s,
            launch_s=0.0,
            boresight_offset_px=(float(offset[0]), float(offset[1])),
        )
        out[cam] = (sensor, feed)
    return out


def calibrate_cameras(feeds: dict, seeds: dict, directory: Path, stem: str) -> dict[str, str]:
    """Blackbody captures of every camera through its own fixed pattern, fitted and saved as
    ``<directory>/<stem>.<camera>-calibration.npz``; returns {camera: path}."""
    from snrmon.acquisition.calibrate.calibration import calibrate_means
    from snrmon.acquisition.calibrate.calibration_file import save_calibration
    from snrmon.sim.from_model import blackbody_scene
    from snrmon.sim.scene import SceneRenderer

    paths = {}
    for cam, (sensor, feed) in feeds.items():
        means, stds = [], []
        for temp in BLACKBODY_K:
            renderer = SceneRenderer(blackbody_scene(feed.scene, sensor, temp), seeds[cam])
            total = np.zeros(feed.scene.shape)
            square = np.zeros(feed.scene.shape)
            for k in range(BLACKBODY_FRAMES):
                # counters far from the flight's: fresh noise, the same fixed pattern
                f = renderer.render(10_000_000 + k, 0.0, None).astype(np.float64)
                total += f
                square += f * f
            n = BLACKBODY_FRAMES
            mean = total / n
            means.append(mean.astype(np.float32))
            stds.append(np.sqrt(np.maximum(square - n * mean * mean, 0.0) / (n - 1)))
        cal = calibrate_means(
            BLACKBODY_K,
            means,
            stds,
            [BLACKBODY_FRAMES] * 2,
            camera=sensor.name,
            band_um=tuple(sensor.band_um),
            t_int_s=sensor.t_int_s,
            qe_curve=tuple(sensor.qe_curve),
        )
        path = directory / f"{stem}.{cam}-calibration.npz"
        save_calibration(cal, path)
        paths[cam] = str(path)
    return paths


class CropLog:
    """The last ``seconds`` of 13 x 13 crops around each valid measured peak of one camera:
    (t_host_ns, crop) with the crop non-uniformity corrected by ``calibration`` if given."""

    def __init__(self, fps: float, seconds: float, calibration=None) -> None:
        self.crops: deque[tuple[int, np.ndarray]] = deque(maxlen=math.ceil(fps * seconds))
        self.calibration = calibration

    def add(self, t_host_ns: int, pixels: np.ndarray, result) -> None:
        from snrmon.acquisition.calibrate.psf_estimate import crop_frames

        if result is None or result.flags or not math.isfinite(result.snr):
            return
        crop = crop_frames([pixels], [(result.peak_x, result.peak_y)], self.calibration)
        if len(crop):
            self.crops.append((int(t_host_ns), crop[0]))

    def between(self, times_ns) -> np.ndarray:
        """The crops at exactly these frame times (a stop row's run), in order."""
        wanted = set(int(t) for t in times_ns)
        got = [c for t, c in list(self.crops) if t in wanted]
        return np.asarray(got).reshape(-1, 13, 13)


def _unresolved_stops(rig, cam: str, finals: dict) -> list:
    from snrmon.acquisition.calibrate.psf_estimate import StopCrops, target_px

    sensor = rig.cameras[cam].sensor
    stops = []
    for (c, stop), entry in sorted(finals.items()):
        crops = entry.get("_crops")
        if c != cam or crops is None or entry.get("lrf_range_m") is None:
            continue
        d = target_px(rig.predictor.target, entry["lrf_range_m"], sensor.ifov_rad)
        if d < 1.0 and len(crops) >= 50:
            stops.append(StopCrops(_label(stop, cam), crops, d))
    return stops


def adopt_measured_psf(rig, cam: str, finals: dict) -> None:
    """Fit the PSF to ``cam``'s unresolved stops so far and hand it to the model (its
    corrected curves and expected Eq. (4) reading), in the background: what an operator does
    once the first unresolved stop is in. The fit (about a second of NumPy) runs in the worker
    process (:mod:`snrmon.acquisition.worker_process`), away from the measurement threads."""
    import time

    from snrmon.acquisition import worker_process
    from snrmon.acquisition.calibrate.psf_estimate import PsfEstimateError, estimate_psf

    stops = _unresolved_stops(rig, cam, finals)
    if not stops:
        return

    def adopt(job) -> None:  # on the worker pool's thread
        try:
            est = job.result()
        except PsfEstimateError:
            return
        except Exception:
            log.exception("%s: the PSF fit failed", cam)
            return
        rig.session.engine.adopt_psf(cam, est.as_dict(), time.monotonic_ns())

    worker_process.submit(estimate_psf, stops, rig.cameras[cam].sensor).add_done_callback(adopt)


def measured_psf(rig, finals: dict) -> dict:
    """Per camera, the PSF fitted to the crops of its unresolved stops, pooled, and every
    stop's expected Eq. (4) with it: {camera: {"psf": {...} | {"error": ...}}} and, in the
    stop entries of ``finals``, ``"expected_eq4_measured_psf"`` (over the whole cell) and, at
    an unresolved stop, ``"expected_eq4_stop_phases"`` (over the phases its frames sampled)."""
    from snrmon.acquisition.calibrate.psf_estimate import (
        PsfEstimateError,
        estimate_psf,
        observed_phases,
    )
    from snrmon.model.snr import predict

    out = {}
    target = rig.predictor.target
    for cam, cam_rig in rig.cameras.items():
        sensor = cam_rig.sensor
        stops = _unresolved_stops(rig, cam, finals)
        if not stops:
            out[cam] = {"error": f"{cam}: no unresolved stop with 50 frames to fit a PSF"}
            continue
        try:
            est = estimate_psf(stops, sensor)
        except PsfEstimateError as exc:
            out[cam] = {"error": str(exc)}
            continue
        out[cam] = est.as_dict()
        sky = rig.predictor.background_temp_k.get(cam)
        phases = {s.label: observed_phases(s, est.psf(), sensor.fill_factor) for s in stops}
        for (c, stop), entry in finals.items():
            rng = entry.get("lrf_range_m")
            if c != cam or rng is None:
                continue
            kw = {
                "corrected_psf": est.psf(),
                "background_temp_k": sky,
                "air_temp_k": rig.opts.scenario.air_temp_k,
                "band": False,
            }
            p = predict(sensor, target, [rng], **kw)
            entry["expected_eq4_measured_psf"] = float(p.expected_eq4[0])
            entry["model_small_corrected_measured_psf"] = float(p.snr_small_corrected[0])
            sampled = phases.get(_label(stop, cam))
            if sampled is not None:  # unresolved: the phases its own frames sampled
                p = predict(sensor, target, [rng], phases_xy=sampled, **kw)
                entry["expected_eq4_stop_phases"] = float(p.expected_eq4[0])
    return out


def _label(stop: int, cam: str) -> str:
    return f"stop {stop} ({cam})"
