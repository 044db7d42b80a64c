"""Everything computed from one camera's frames, frame after frame: one class for live and replay.

Per frame, in this order (:meth:`CameraAnalysis.analyze`):

1. the background reference capture (a temporal average of clear-sky frames) is fed, if one is
   running (:class:`acquisition.engine.frame_correction.FrameCorrector`);
2. Eq. (4) with the tracker on the corrected window (:class:`acquisition.engine.frame_measurer.
   FrameMeasurer`), and, while a correction is on, the same track on the raw frame, so that the
   console reports the SNR with and without the fixed-pattern removal (paper section 6);
3. the section 6 noise figures (total, temporal, spatial) of the raw pixels around the track
   (:class:`acquisition.measure.track_noise.TrackNoise`, a few times a second);
4. with a radiometric calibration, the apparent sky temperature of the background pixels
   (:class:`acquisition.calibrate.sky_temperature.SkyTemperature`; paper sections 8-9).

The live :class:`acquisition.runtime.camera_pipeline.CameraPipeline` and the console's
:class:`acquisition.replay.player.ReplayPlayer` both run this class, so a replay shows the same
numbers the operator saw live. One thread (the measurement thread, or the replay worker) owns
an instance and calls everything but :meth:`figures`, which any thread may read: it only picks
up whole values that the owner publishes.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from acquisition.engine.frame_correction import FrameCorrector
from acquisition.engine.frame_measurer import FrameMeasurer, FrameResult, crop_half_px
from acquisition.measure.peak_snr import PeakSnrConfig
from acquisition.measure.track_noise import TrackNoise
from acquisition.track.tracker import TrackerConfig

log = logging.getLogger(__name__)

SKY_FRAMES = 100  # the sky temperature shown: the mean over the last 100 frames, like the SNR


@dataclass(frozen=True, slots=True)
class FrameAnalysis:
    """One frame's outcome: the measurement (None without an ROI), the raw-frame track's
    running SNR (NaN without a correction), and the reference just completed on this frame
    (its summary for the record) or None."""

    result: FrameResult | None
    snr_mean_raw: float
    snr_std_raw: float
    reference_done: dict | None


@dataclass(frozen=True, slots=True)
class AnalysisFigures:
    """The camera's slowly changing figures for the status (units in the names)."""

    reference_frames: int
    fixed_pattern_dn: float
    sky_temp_k: float
    noise_total_dn: float
    noise_temporal_dn: float
    noise_spatial_dn: float


class CameraAnalysis:
    """The per-frame analysis of one camera (module docstring).

    Args:
        name: the camera's name (for messages).
        shape: (rows, columns) of its frames.
        config: the Eq. (4) settings.
        window: frames in the running statistics (the paper's 100).
        track: follow the drone from the click; False keeps the window where it was put.
        tracker_config: the tracker's own numbers (its Eq. 4 settings are ``config``).
    """

    def __init__(
        self,
        name: str,
        shape: tuple[int, int],
        config: PeakSnrConfig | None = None,
        *,
        window: int = 100,
        track: bool = True,
        tracker_config: TrackerConfig | None = None,
    ) -> None:
        self.name = name
        self.shape = (int(shape[0]), int(shape[1]))
        kw = {"window": window, "track": track, "tracker_config": tracker_config}
        self.measurer = FrameMeasurer(config, **kw)
        self.raw_measurer = FrameMeasurer(config, **kw)
        cfg = self.measurer.meter.config
        self.corrector = FrameCorrector(self.shape, crop_half_px(cfg, self.measurer.tracker_config))
        self.noise = self._track_noise(cfg)
        self.sky = None  # SkyTemperature, with a calibration

    def _track_noise(self, cfg: PeakSnrConfig) -> TrackNoise:
        kw = {"box_px": cfg.box_px, "detrend": cfg.detrend, "ddof": cfg.ddof}
        try:
            return TrackNoise(self.shape, background=cfg.background, **kw)
        except ValueError as exc:  # a rectangle off this image: noise around the track instead
            log.warning("%s: clear-sky rectangle not used for the noise: %s", self.name, exc)
            return TrackNoise(self.shape, **kw)

    # ------------------------------------------------------------------ commands
    @property
    def roi(self) -> tuple[int, int] | None:
        return self.measurer.roi

    def set_roi(self, x: int, y: int) -> None:
        """A click: both tracks start afresh at (x, y)."""
        self.measurer.set_roi(x, y)
        self.raw_measurer.set_roi(x, y)

    def clear_roi(self) -> None:
        self.measurer.clear_roi()
        self.raw_measurer.clear_roi()

    def cue(self, x: float, y: float) -> None:
        """A projected GPS position for both trackers to reacquire near."""
        self.measurer.cue(x, y)
        self.raw_measurer.cue(x, y)

    def set_calibration(self, calibration) -> None:
        """Correct the measured window with a radiometric calibration and follow the apparent
        sky temperature of the background pixels
        (:class:`acquisition.calibrate.calibration.Calibration`)."""
        from acquisition.calibrate.sky_temperature import SkyTemperature

        self.corrector.calibration = calibration
        box = self.measurer.meter.config.box_px
        self.sky = SkyTemperature(self.name, calibration, box_px=box, maxlen=600)

    def start_reference(self, n_frames: int) -> None:
        """Average the next ``n_frames`` frames into the background reference."""
        self.corrector.start_reference(n_frames)

    def clear_reference(self) -> None:
        self.corrector.clear_reference()

    def set_reference(self, frames: np.ndarray, counters) -> None:
        """A reference from frames at hand (a replay applies the recorded one)."""
        self.corrector.set_reference(frames, counters)
        self._raw_track_from_here()

    def _raw_track_from_here(self) -> None:
        # The raw track starts where the corrected track is when the correction begins.
        if self.measurer.roi is not None:
            self.raw_measurer.set_roi(*self.measurer.roi)

    # ------------------------------------------------------------------ per frame
    def analyze(self, pixels: np.ndarray, counter: int, t_host_ns: int) -> FrameAnalysis:
        """Analyse one raw frame (rows, columns) with the camera's ``counter``."""
        corrector = self.corrector
        done = None
        if corrector.capturing:
            done = corrector.feed(pixels, counter)
            if done is not None:
                self._raw_track_from_here()
        fr = self.measurer.measure(corrector.apply(pixels, self.measurer.read_xy))
        raw = self.raw_measurer.measure(pixels) if corrector.active else None
        peak_xy = None if fr is None else (fr.result.peak_x, fr.result.peak_y)
        self.noise.update(pixels, t_host_ns, peak_xy)  # raw pixels: the camera's own FPN
        if fr is not None and self.sky is not None:
            self.sky.add(t_host_ns, pixels, fr.result)
        nan = math.nan
        return FrameAnalysis(
            fr,
            raw.snr_mean if raw is not None else nan,
            raw.snr_std if raw is not None else nan,
            done,
        )

    def figures(self) -> AnalysisFigures:
        total, temporal, spatial = self.noise.figures()
        sky = self.sky.mean_temp_k(last=SKY_FRAMES) if self.sky is not None else math.nan
        return AnalysisFigures(
            self.corrector.reference_frames,
            self.corrector.fixed_pattern_dn,
            sky,
            total,
            temporal,
            spatial,
        )
