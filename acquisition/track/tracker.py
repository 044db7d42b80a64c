"""The track: keeps the Eq. (4) search window on a faint drone from frame to frame.

After the operator's click the window follows the peak, but only within a motion gate: the drone
hovers, so a peak that jumps farther than ``gate_px`` between frames is not the drone (a bird, an
aircraft, a cloud edge entering the window). Lost track is a state, shown and recorded, never a
silent jump; the drone's GPS position projected into the image (:mod:`acquisition.geo.projection`)
cues the
search to find it again, as the paper's operators did (section 7).

Per frame (:meth:`Tracker.update`):

1. Measure Eq. (4) with :func:`acquisition.measure.peak_snr.peak_snr_with` and the measurement's own
   :class:`~acquisition.measure.peak_snr.PeakSnrConfig` (one source of the Eq. 4 settings) in the
   search
   window (``search_px``, default 11) centred on the window centre = the last accepted peak.
2. Judge the candidate, in this order: SNR undefined -> ``undefined``; peak farther than
   ``gate_px`` from the last accepted peak (Chebyshev distance, max(|dx|, |dy|)) -> ``gate``; peak
   contrast (peak - bg_mean) above ``brightness_factor`` x the median contrast of the last
   ``brightness_frames`` accepted frames (once there are ``brightness_min_frames``) -> ``bright``;
   rim contaminated (the measurement's own flag) -> ``contaminated``; SNR below ``lost_snr``, or
   contrast below that median / ``brightness_factor`` (a noise peak where the drone vanished) ->
   ``faint``; else accepted.
3. Refused by the gate: search again only inside the gate (a ``2 gate_px + 1`` square around the
   last peak) and judge that candidate the same way; its measurement is the frame's output.
4. Accepted: the window centre moves to the peak. Anything else is a miss and the window holds.
   A frame refused by ``gate`` or ``bright`` gets the ``lost`` flag (its measurement is not the
   drone's); ``faint`` frames are genuine measurements of a faint drone and keep their flags.
5. ``lost_frames`` consecutive misses -> state LOST: every frame is flagged ``lost`` and the window
   holds until a cue or a new click (no automatic reacquisition: a bird near the old position
   must not capture a lost track).
6. :meth:`Tracker.cue` gives the projected GPS position. While LOST, the search runs in a
   ``2 cue_radius_px + 1`` square around the latest cue (no older than ``cue_max_age_frames``);
   a candidate with SNR >= ``reacquire_snr`` that passes the brightness and contamination tests
   reacquires: state GPS_CUED, frames flagged ``gps_cued``, until ``confirm_frames`` consecutive
   accepted frames make it TRACKING again.

The first frame after a click has no gate (the operator's click is the prior). When the window
never moves, every output is bit-identical to :func:`~acquisition.measure.peak_snr.peak_snr_with`
at that
point with the same configuration and ``reference_noise``: the tracker calls it, and only adds
``lost``/``gps_cued``.

The rim-contamination reference (``reference_noise``): ``"recent"`` (default) keeps the same
recent-noise median as :class:`acquisition.measure.peak_snr.PeakSnrMeter`, fed with the tracker's
output
frames; a number fixes it (DN); None skips the contamination test.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from enum import Enum

import numpy as np

from acquisition.measure.contamination import NoiseReference
from acquisition.measure.peak_snr import (
    FLAG_GPS_CUED,
    FLAG_LOST,
    FLAG_RIM_CONTAMINATED,
    RUNNING_EXCLUDED,
    PeakSnr,
    PeakSnrConfig,
    peak_snr_with,
    pixel_of,
)


class TrackState(Enum):
    """What the track is doing; shown to the operator and recorded."""

    TRACKING = "tracking"
    LOST = "lost"
    GPS_CUED = "gps_cued"


@dataclass(frozen=True)
class TrackerConfig:
    """Every number of the tracker (module docstring). The Eq. (4) settings it measures with
    (search window, box, background, contamination test) are a :class:`PeakSnrConfig`, given
    to :class:`Tracker` beside this, so that tracking and fixed-point measurement share them."""

    gate_px: int = 3
    lost_snr: float = 3.0
    lost_frames: int = 10
    brightness_factor: float = 3.0
    brightness_frames: int = 25
    brightness_min_frames: int = 5
    cue_radius_px: int = 15
    cue_max_age_frames: int = 60
    reacquire_snr: float = 5.0
    confirm_frames: int = 5

    def __post_init__(self) -> None:
        for name in ("gate_px", "cue_radius_px"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"tracker {name} must be an integer >= 1, got {v}")
        for name in ("lost_frames", "confirm_frames", "brightness_frames", "cue_max_age_frames"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"tracker {name} must be an integer >= 1, got {v}")
        if not 1 <= self.brightness_min_frames <= self.brightness_frames:
            raise ValueError(
                f"tracker brightness_min_frames must be in 1..{self.brightness_frames}, "
                f"got {self.brightness_min_frames}"
            )
        for name in ("lost_snr", "reacquire_snr", "brightness_factor"):
            v = getattr(self, name)
            if math.isnan(v) or (name == "brightness_factor" and v <= 1):
                raise ValueError(f"tracker {name} must be a number (factor > 1), got {v}")


@dataclass(frozen=True, slots=True)
class TrackStep:
    """One frame's outcome.

    Attributes:
        peak_snr: the Eq. (4) measurement output for this frame (with ``lost``/``gps_cued``).
        state: the track state after this frame.
        window_x, window_y: centre of the search window the output was measured in.
        search_px: that window's size (the normal window, the gate, or the cue square).
        reason: "" when accepted, else why not: undefined, gate, bright, contaminated, faint,
            no_cue (lost, no usable cue).
        misses: consecutive frames not accepted.
    """

    peak_snr: PeakSnr
    state: TrackState
    window_x: int
    window_y: int
    search_px: int
    reason: str
    misses: int


_REFUSED = frozenset({"gate", "bright"})


class Tracker:
    """Follows the drone from the operator's click (:meth:`click`) frame by frame."""

    def __init__(
        self,
        at_xy: tuple[float, float],
        config: TrackerConfig | None = None,
        *,
        measurement: PeakSnrConfig | None = None,
        reference_noise: float | str | None = "recent",
        **settings,
    ) -> None:
        if config is not None and settings:
            raise ValueError("give either config or settings, not both")
        self.config = config if config is not None else TrackerConfig(**settings)
        self.measurement = measurement if measurement is not None else PeakSnrConfig()
        # One configuration per window size the tracker searches (normal, gate, cue square),
        # built once: each keeps its cached background offsets.
        self._configs: dict[int, PeakSnrConfig] = {self.measurement.search_px: self.measurement}
        if not (reference_noise is None or reference_noise == "recent") and (
            isinstance(reference_noise, str) or not math.isfinite(reference_noise)
        ):
            raise ValueError(
                f"reference_noise must be 'recent', a number (DN) or None, got {reference_noise!r}"
            )
        self._fixed_reference = reference_noise
        m = self.measurement
        self._reference = NoiseReference(m.reference_frames, m.reference_min_frames)
        self._contrasts: deque[float] = deque(maxlen=self.config.brightness_frames)
        self._cue: tuple[float, float] | None = None
        self._cue_age = 0
        self.click(at_xy)

    # ----------------------------------------------------------------------------- commands
    def click(self, at_xy: tuple[float, float]) -> None:
        """The operator's click: the window goes there, the track starts afresh (TRACKING)."""
        self._window = pixel_of(at_xy)
        self._anchored = False  # no accepted peak yet: the first frame is not gated
        self._misses = 0
        self._confirmed = 0
        self.state = TrackState.TRACKING
        self._contrasts.clear()
        self._reference.clear()

    def cue(self, x: float, y: float) -> None:
        """The drone's GPS position projected into this camera (pixels). Used while LOST;
        remembered (for the GUI's marker) otherwise. A non-finite position is a ValueError."""
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"GPS cue must be a finite pixel position, got ({x}, {y})")
        self._cue = (float(x), float(y))
        self._cue_age = 0

    def snapshot(self) -> dict:
        """The track's complete state, exactly (JSON-able): a tracker of the same configuration
        given it with :meth:`restore` continues bit-identically (the replay of a recording
        across frames measured live but missing from the file)."""
        return {
            "window": list(self._window),
            "anchored": self._anchored,
            "misses": self._misses,
            "confirmed": self._confirmed,
            "state": self.state.value,
            "contrasts": list(self._contrasts),
            "reference": self._reference.snapshot(),
            "cue": None if self._cue is None else list(self._cue),
            "cue_age": self._cue_age,
        }

    def restore(self, state: dict) -> None:
        x, y = state["window"]
        self._window = (int(x), int(y))
        self._anchored = bool(state["anchored"])
        self._misses = int(state["misses"])
        self._confirmed = int(state["confirmed"])
        self.state = TrackState(state["state"])
        self._contrasts.clear()
        self._contrasts.extend(float(v) for v in state["contrasts"])
        self._reference.restore(state["reference"])
        cue = state["cue"]
        self._cue = None if cue is None else (float(cue[0]), float(cue[1]))
        self._cue_age = int(state["cue_age"])

    @property
    def last_cue(self) -> tuple[float, float] | None:
        return self._cue

    @property
    def window_xy(self) -> tuple[int, int]:
        """Where the next frame's search window is centred."""
        return self._window

    @property
    def reference_noise(self) -> float | None:
        """The contamination reference (DN) the next frame is measured against."""
        if self._fixed_reference == "recent":
            return self._reference.value
        return self._fixed_reference  # type: ignore[return-value]

    # ----------------------------------------------------------------------------- per frame
    def update(self, pixels: np.ndarray) -> TrackStep:
        """Measure and track one frame (rows, columns)."""
        if self._cue is not None:
            self._cue_age += 1
        ref = self.reference_noise
        if self.state is TrackState.LOST:
            step = self._search_lost(pixels, ref)
        else:
            step = self._follow(pixels, ref)
        m = step.peak_snr
        self._reference.update(
            m.bg_std,
            accepted=not m.flags & RUNNING_EXCLUDED,
            rejected=FLAG_RIM_CONTAMINATED in m.flags,
        )
        return step

    def _measure(self, pixels, at, search_px, ref) -> PeakSnr:
        cfg = self._configs.get(search_px)
        if cfg is None:
            cfg = self._configs[search_px] = dataclasses.replace(
                self.measurement, search_px=search_px
            )
        return peak_snr_with(pixels, at, cfg, reference_noise=ref)

    def _judge(self, m: PeakSnr, *, gated: bool, min_snr: float) -> str:
        if not math.isfinite(m.snr):
            return "undefined"
        if gated and self._anchored:
            wx, wy = self._window
            if max(abs(m.peak_x - wx), abs(m.peak_y - wy)) > self.config.gate_px:
                return "gate"
        c = self.config
        if len(self._contrasts) >= c.brightness_min_frames:
            typical = statistics.median(self._contrasts)
            contrast = m.peak - m.bg_mean
            if typical > 0 and contrast > c.brightness_factor * typical:
                return "bright"
            if typical > 0 and contrast * c.brightness_factor < typical:
                # Implausibly dim: the drone is gone and this is a noise peak. Following it
                # would walk the window off the drone's last position.
                return "faint"
        if FLAG_RIM_CONTAMINATED in m.flags:
            return "contaminated"
        if m.snr < min_snr:
            return "faint"
        return ""

    def _follow(self, pixels, ref) -> TrackStep:
        c = self.config
        at = self._window
        size = self.measurement.search_px
        m = self._measure(pixels, at, size, ref)
        reason = self._judge(m, gated=True, min_snr=c.lost_snr)
        if reason == "gate":
            size = 2 * c.gate_px + 1
            m = self._measure(pixels, at, size, ref)
            reason = self._judge(m, gated=True, min_snr=c.lost_snr)
        extra: set[str] = set()
        if reason == "":
            self._accept(m)
            if self.state is TrackState.GPS_CUED:
                self._confirmed += 1
                if self._confirmed >= c.confirm_frames:
                    self.state = TrackState.TRACKING
        else:
            self._misses += 1
            self._confirmed = 0
            if reason in _REFUSED:
                extra.add(FLAG_LOST)
            if self._misses >= c.lost_frames:
                self.state = TrackState.LOST
        if self.state is TrackState.LOST:
            extra.add(FLAG_LOST)
        elif self.state is TrackState.GPS_CUED:
            extra.add(FLAG_GPS_CUED)
        return self._step(m, at, size, reason, extra)

    def _search_lost(self, pixels, ref) -> TrackStep:
        c = self.config
        rows, cols = pixels.shape
        cue = self._cue if self._cue_age <= c.cue_max_age_frames else None
        if cue is not None:
            cx, cy = pixel_of(cue)
            if 0 <= cx < cols and 0 <= cy < rows:
                size = 2 * c.cue_radius_px + 1
                m = self._measure(pixels, (cx, cy), size, ref)
                reason = self._judge(m, gated=False, min_snr=c.reacquire_snr)
                if reason == "":
                    self._accept(m)
                    self._cue = None  # used: a later loss needs a fresh position
                    self.state = TrackState.GPS_CUED
                    self._confirmed = 1
                    return self._step(m, (cx, cy), size, "", {FLAG_GPS_CUED})
                self._misses += 1
                return self._step(m, (cx, cy), size, reason, {FLAG_LOST})
        self._misses += 1
        size = self.measurement.search_px
        m = self._measure(pixels, self._window, size, ref)
        return self._step(m, self._window, size, "no_cue", {FLAG_LOST})

    def _accept(self, m: PeakSnr) -> None:
        self._window = (m.peak_x, m.peak_y)
        self._anchored = True
        self._misses = 0
        self._contrasts.append(m.peak - m.bg_mean)

    def _step(self, m: PeakSnr, at, size: int, reason: str, extra: set[str]) -> TrackStep:
        if extra - m.flags:
            m = dataclasses.replace(m, flags=m.flags | extra)
        return TrackStep(m, self.state, int(at[0]), int(at[1]), size, reason, self._misses)


def track_stack(
    stack: np.ndarray,
    at_xy: tuple[float, float],
    config: TrackerConfig | None = None,
    *,
    measurement: PeakSnrConfig | None = None,
    cues: Iterable[tuple[float, float] | None] | None = None,
    reference_noise: float | str | None = "recent",
) -> list[TrackStep]:
    """Run a :class:`Tracker` over a stack (N, rows, columns) from the click ``at_xy``;
    ``cues``: per frame, a projected GPS position given before that frame, or None."""
    if stack.ndim != 3:
        raise ValueError(f"a stack must be 3-D (frames, rows, columns), got shape {stack.shape}")
    tracker = Tracker(at_xy, config, measurement=measurement, reference_noise=reference_noise)
    cue_list = list(cues) if cues is not None else [None] * len(stack)
    if len(cue_list) != len(stack):
        raise ValueError(f"{len(cue_list)} cues for {len(stack)} frames")
    steps = []
    for frame, cue in zip(stack, cue_list, strict=True):
        if cue is not None:
            tracker.cue(*cue)
        steps.append(tracker.update(frame))
    return steps
