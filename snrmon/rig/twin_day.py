"""The simulated collection day's twin cameras and their calibration at the start of the day
(the PSF measured from the flight at its end is the rig's: :meth:`snrmon.rig.rig.HilRig.
measured_psf`).

* :func:`camera_feeds`: each camera's renderer is the digital twin of :mod:`snrmon.sim.twin` (its
  own optics and the drone's outline; the scenario's sky and air), not the model's PSF.
* :func:`calibrate_cameras`: as a field day starts, each camera looks into an extended
  blackbody at two temperatures; the frames go through the camera's very fixed-pattern gain and
  offset (the same renderer, the same seed) and are accumulated into the per-pixel mean and
  temporal std, and ``acquisition.calibrate.calibration.calibrate_means`` makes the two-point
  calibration, saved as a file the session configuration names (so the session applies it,
  follows the sky temperature with it and records it).

The crops a stop's frames give the PSF from are the session's own
(:mod:`snrmon.acquisition.calibrate.flight_psf`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from snrmon.model.constants import ZERO_C_K

BLACKBODY_K = (ZERO_C_K, ZERO_C_K + 45.0)
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
    from snrmon.sim.scene import SceneRenderer
    from snrmon.sim.twin import blackbody_scene

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
