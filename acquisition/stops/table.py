"""The SNR-versus-range table, built live stop by stop (paper section 7, Figs. 7-10).

Each row is one stop and one camera: the stop's rangefinder and GPS ranges, the mean and sample
std of the peak SNR over the first 100 consecutive valid frames
(:func:`acquisition.stops.detector.summarise_stop`), and the model's curves at that range. Stops
are found
by :class:`acquisition.stops.detector.StopDetector` (or marked by the operator); because a stop's
start is
backdated to when the hover began, the table keeps a short history of each camera's measurements
and takes a stop's frames from it. A row is frozen once it is complete or its stop has ended.
"""

from __future__ import annotations

import threading
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field

from acquisition.measure.peak_snr import PeakSnr
from acquisition.stops.detector import Stop, StopDetector, StopSummary, summarise_stop

Predictor = Callable[[str, float], dict[str, float]]
"""``predict(camera, range_m) -> {"small": snr, "large": ..., "small_corrected": ..., ...}``."""


@dataclass(frozen=True)
class StopRow:
    camera: str
    stop: int
    manual: bool
    t_start_ns: int
    t_end_ns: int | None
    lrf_range_m: float | None
    gps_range_m: float | None
    n_frames: int
    complete: bool
    snr_mean: float
    snr_std: float
    model_snr: dict[str, float] = field(default_factory=dict)
    resolved: bool | None = None  # the model's verdict for the small dimension at this range
    # The background(s) the summarised frames were measured against (rim, extent_rim, rect),
    # most used first, joined by "+"; "" without frames.
    background: str = ""

    @property
    def range_m(self) -> float | None:
        """The stop's range: the rangefinder's when it has one, else the GPS slant range."""
        return self.lrf_range_m if self.lrf_range_m is not None else self.gps_range_m


def backgrounds_of(results) -> str:
    """The background methods of some measurements, most used first, joined by "+"."""
    counts = Counter(r.background for r in results)
    return "+".join(name for name, _ in counts.most_common())


class StopTable:
    """Collects each camera's measurements and summarises them per stop (thread-safe)."""

    def __init__(
        self,
        detector: StopDetector,
        cameras: list[str],
        *,
        frames_per_stop: int = 100,
        history_frames: int = 4000,
        predictor: Predictor | None = None,
        on_final: Callable[[StopRow], None] | None = None,
    ) -> None:
        self.on_final = on_final
        self.detector = detector
        self.cameras = list(cameras)
        self.n = frames_per_stop
        self.predictor = predictor
        self._lock = threading.Lock()
        self._recent: dict[str, deque[tuple[int, PeakSnr]]] = {
            c: deque(maxlen=history_frames) for c in self.cameras
        }
        self._frozen: dict[tuple[int, str], StopRow] = {}
        # The frames each final row summarised (paper Fig. 6), kept because the history
        # deque forgets them within a minute.
        self._runs: dict[tuple[int, str], list[tuple[int, PeakSnr]]] = {}

    def add(self, camera: str, t_host_ns: int, result: PeakSnr) -> None:
        """One measured frame of ``camera`` (called on its measurement thread)."""
        with self._lock:
            self._recent[camera].append((int(t_host_ns), result))

    def rows(self) -> list[StopRow]:
        """Every stop so far x every camera, in stop order. A row is final once it has its
        100 frames or its stop ended; ``on_final(row)`` is called once for each."""
        with self._lock:
            stops = self.detector.stops
            out = []
            for stop in stops:
                for cam in self.cameras:
                    key = (stop.index, cam)
                    row = self._frozen.get(key)
                    if row is None:
                        row, run = self._row(stop, cam)
                        if row.complete or stop.t_end_ns is not None:
                            self._frozen[key] = row
                            self._runs[key] = run
                            if self.on_final is not None:
                                self.on_final(row)
                    out.append(row)
            return out

    def runs(self) -> dict[tuple[int, str], list[tuple[int, PeakSnr]]]:
        """``{(stop, camera): [(t_host_ns, PeakSnr), ...]}``: the frames each final row's
        statistics were taken from, in order (the first ``frames_per_stop`` consecutive valid
        frames, or the longest run of a stop that ended short)."""
        with self._lock:
            return {k: list(v) for k, v in self._runs.items()}

    def run_of(self, stop: int, camera: str) -> list[tuple[int, PeakSnr]]:
        """The frames row ``(stop, camera)`` is summarised from, as of now: the final run of a
        frozen row, else the run so far (empty for an unknown row)."""
        with self._lock:
            run = self._runs.get((stop, camera))
            if run is not None:
                return list(run)
            match = [s for s in self.detector.stops if s.index == stop]
            if not match or camera not in self._recent:
                return []
            return self._run(match[0], camera)[1]

    def _run(self, stop: Stop, camera: str) -> tuple[StopSummary, list[tuple[int, PeakSnr]]]:
        entries = [(t, r) for t, r in self._recent[camera] if stop.contains(t)]
        summary = summarise_stop([r for _, r in entries], self.n)
        return summary, entries[summary.frames]

    def _row(self, stop: Stop, camera: str) -> tuple[StopRow, list[tuple[int, PeakSnr]]]:
        summary, run = self._run(stop, camera)
        rng = stop.lrf_range_m if stop.lrf_range_m is not None else stop.gps_range_m
        model = dict(self.predictor(camera, rng)) if (self.predictor and rng) else {}
        resolved = model.pop("resolved_small", None)
        row = StopRow(
            camera=camera,
            stop=stop.index,
            manual=stop.manual,
            t_start_ns=stop.t_start_ns,
            t_end_ns=stop.t_end_ns,
            lrf_range_m=stop.lrf_range_m,
            gps_range_m=stop.gps_range_m,
            n_frames=summary.n_frames,
            complete=summary.complete,
            snr_mean=summary.snr_mean,
            snr_std=summary.snr_std,
            model_snr=model,
            resolved=None if resolved is None else bool(resolved),
            background=backgrounds_of(r for _, r in run),
        )
        return row, run
