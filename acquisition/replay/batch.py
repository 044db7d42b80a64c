"""Batch replay of a recorded session: the whole timeline through the live engine.

:func:`replay_session` builds the session's engine with the recording's own settings (or the ones
given: a re-analysis), plays the recording's timeline into it
(:class:`snrmon.acquisition.replay.feeder.Feeder`), paced to the recorded clock or as fast as the
disk allows, and returns every per-frame measurement, the comparison with the recorded ones, the
stop table, and the file's own frame accounting (what the recorder dropped, and why). As fast as
it can, with several cameras and a core idle, it plays each camera through an engine of its own
in a process of its own (:mod:`snrmon.acquisition.replay.forked`): the same results.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from snrmon.acquisition.calibrate.flight_psf import FlightPsf
from snrmon.acquisition.calibrate.stop_phases import stop_phase_readings
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.engine.status import FrameAccounting
from snrmon.acquisition.measure.peak_snr import PeakSnr, PeakSnrConfig
from snrmon.acquisition.prediction import Predictor
from snrmon.acquisition.record.reader import SessionFile, open_session
from snrmon.acquisition.replay.feeder import CameraTally, Feeder, RecordedStops
from snrmon.acquisition.replay.forked import Forked, can_fork, idle_core
from snrmon.acquisition.replay.recorded import (
    FRAME,
    RecordedInputs,
    recorded_calibration,
    recorded_inputs,
    recording_drops,
)
from snrmon.acquisition.stops.table import StopRow, row_values_equal


@dataclass
class CameraReplay:
    """One camera's replay: every measurement, and how it compares with the recording."""

    name: str
    n_frames: int  # frames in the file
    tally: CameraTally
    dropped: dict[str, int] = field(default_factory=dict)  # the recorder's drops, by reason
    # What became of every frame the console received, as the recording's summary keeps it;
    # None for a file without it.
    accounting: FrameAccounting | None = None

    @property
    def results(self) -> list[PeakSnr]:
        return [m.result for m in self.tally.measurements]

    @property
    def t_host_ns(self) -> list[int]:
        return [m.t_host_ns for m in self.tally.measurements]

    @property
    def identical(self) -> int:
        return self.tally.identical

    @property
    def compared(self) -> int:
        return self.tally.compared


@dataclass
class ReplayResult:
    cameras: dict[str, CameraReplay]
    stops: list[StopRow]
    seconds: float
    recording_seconds: float
    recorded_rows: dict[tuple[int, str], dict]  # the live session's final rows, as recorded
    stops_identical: int | None  # final rows equal to the recorded ones (None: none recorded)
    format_version: str
    processes: int = 1  # the processes the cameras were played in (replay_session's parallel)

    @property
    def realtime_factor(self) -> float:
        return self.recording_seconds / self.seconds if self.seconds > 0 else math.inf


def as_recorded(
    inputs: RecordedInputs,
    cameras: Sequence[str],
    measurement: PeakSnrConfig | None,
    track: bool,
    calibrations: Mapping[str, str] | None,
) -> bool:
    """True when the settings given are the live session's own (None or equal to the recorded
    ones): the replay then applies the live cues and engine states and reproduces every
    recorded frame. Settings that differ are a re-analysis, which measures afresh. Passing the
    recorded settings explicitly (as the campaign does) is not a re-analysis."""
    if measurement is not None and measurement != inputs.config.measurement:
        return False
    if track != inputs.track:
        return False
    for name in cameras:
        path = (calibrations or {}).get(name)
        if path is not None and path != inputs.per_camera[name].calibration:
            return False
    return True


def engine_for(
    f: SessionFile,
    inputs: RecordedInputs,
    *,
    cameras: Sequence[str],
    track: bool,
    measurement: PeakSnrConfig | None,
    calibrations: Mapping[str, str] | None,
    predictor: Predictor | None,
    redetect_stops: bool,
    fast: bool = False,
    display: bool = False,
) -> tuple[SessionEngine, Feeder]:
    """The session's engine as the live console built it (its stop rows held to their frames'
    sub-pixel phases as live: :func:`stop_phase_readings`), and the feeder that replays into it
    (shared by the batch replay and the console's player)."""
    config = inputs.config
    if measurement is not None:
        config = replace(config, measurement=measurement)
    exact = inputs.version >= 2 and as_recorded(inputs, cameras, measurement, track, calibrations)
    # The live session's own stops where it recorded them (format 2 with stop events).
    stops = RecordedStops() if inputs.stops and not redetect_stops else None
    shapes = {n: tuple(f.cameras[n].frames.shape[1:]) for n in cameras}
    engine = SessionEngine(
        config,
        shapes,
        track=track,
        stop_config=inputs.stop_config,
        stops=stops,
        predictor=predictor,
        cue_from_gps=not exact,
        follow_sky=not exact,
        project_gps=display,
    )
    for name in cameras:
        # Format 2.1 on: the live engine told the tracker about dropped frames (schema.py).
        engine.cameras[name].tell_gaps = f.version >= (2, 1)
        engine.cameras[name].display_figures = display  # no display: no raw-SNR or noise figure
        cal = recorded_calibration(f, name, (calibrations or {}).get(name))
        if cal is not None:
            engine.cameras[name].set_calibration(cal[0])
            if exact and not display:  # the model's sky is the recorded one: nobody reads it
                engine.cameras[name].sky = None
    # The rows the live session held to their frames' sub-pixel phases, held so again: the
    # crops logged from the recorded frames as they play (the live log made them of the same).
    crop_log = FlightPsf(
        engine,
        cameras,
        calibration_of=lambda name: engine.cameras[name].corrector.calibration,
        adopt=False,
    )
    stop_phase_readings(engine, crop_log)
    feeder = Feeder(f, inputs, engine, fast=fast, recorded_stops=stops)
    feeder.exact_inputs = exact
    return engine, feeder


def replay_session(
    path: str | Path,
    *,
    cameras: Sequence[str] | None = None,
    speed: float | None = None,
    fast: bool = False,
    track: bool | None = None,
    measurement: PeakSnrConfig | None = None,
    calibrations: Mapping[str, str] | None = None,
    predictor: Predictor | None = None,
    redetect_stops: bool = False,
    progress: Callable[[int, int], None] | None = None,
    parallel: bool = True,
) -> ReplayResult:
    """Measure every recorded frame again through the live engine (module docstring).

    Args:
        cameras: replay only these (default: all the file holds).
        speed: pace to the recorded clock (1 = real time); None runs as fast as possible.
        fast: read only the pixels the measurement touches (a memory map of the file).
        track: None follows the recording (tracking on or off as it was live).
        measurement: Eq. (4) settings in place of the recorded ones (a re-analysis: the live
            cues and states no longer apply, the stops are still the recorded ones).
        calibrations: a calibration file per camera in place of the recorded ones.
        predictor: the model for the stop table's model column.
        redetect_stops: detect the stops again from the readings instead of using the ones the
            live session recorded.
        progress: ``progress(done, total)`` every 500 timeline entries (of the cameras played
            in this process).
        parallel: play each camera in a process of its own where that gives the same results
            (unpaced, no model, frames memory-mapped: :func:`_may_fork`) and a core is idle
            to run it (:func:`snrmon.acquisition.replay.forked.idle_core`); False plays them
            all in this one.
    """
    with open_session(path) as f:
        inputs = recorded_inputs(f)
        names = list(cameras) if cameras is not None else inputs.cameras
        unknown = [n for n in names if n not in f.cameras]
        if unknown:
            raise ValueError(
                f"{Path(path).name} has no camera {unknown[0]!r} (it holds "
                f"{', '.join(f.cameras) or 'none'})"
            )
        settings: dict[str, Any] = dict(
            track=inputs.track if track is None else track,
            measurement=measurement,
            calibrations=calibrations,
            predictor=predictor,
            redetect_stops=redetect_stops,
            fast=fast,
        )
        plays = _plays(f, inputs, names, settings, apart=parallel and speed is None)
        t_start = time.monotonic()
        played = _played(plays, speed, t_start, progress)
        seconds = time.monotonic() - t_start
        order = {n: i for i, n in enumerate(names)}
        rows = sorted((r for p in played for r in p[1]), key=lambda r: (r.stop, order[r.camera]))
        tallies = {n: t for p in played for n, t in p[0].items()}
        recorded = {k: v for k, v in inputs.final_rows.items() if k[1] in names}
        return ReplayResult(
            _camera_replays(f, names, tallies),
            rows,
            seconds,
            _span_s(f, names),
            recorded,
            _count_identical(rows, recorded) if recorded else None,
            f.format_version,
            len(plays),
        )


def _plays(
    f: SessionFile, inputs: RecordedInputs, names: list[str], settings: dict, *, apart: bool
) -> list[_Play]:
    """The replays to run, the one of this process first: one per camera when they may play
    ``apart`` (unpaced), without a model, a core is idle and every camera is held in memory
    (:func:`_may_fork`), else one of every camera."""
    groups = [names]
    if apart and settings["predictor"] is None and len(names) > 1 and can_fork() and idle_core():
        groups = [[n] for n in names]
    plays = [_Play(f, inputs, group, settings) for group in groups]
    # The camera with the most frames plays here, the others each in a forked child.
    plays.sort(key=lambda p: -sum(f.cameras[n].n_frames for n in p.names))
    if not _may_fork(plays[1:]):
        plays = [_Play(f, inputs, names, settings)]
    return plays


def _played(
    plays: list[_Play],
    speed: float | None,
    t_start: float,
    progress: Callable[[int, int], None] | None,
) -> list[tuple[dict[str, CameraTally], list[StopRow]]]:
    """What each play gave (:meth:`_Play.run`): the first here, the others in forked children."""
    children: list[Forked] = []
    try:
        for p in plays[1:]:
            children.append(Forked(functools.partial(p.run, None, t_start, None)))
        played = [plays[0].run(speed, t_start, progress)]
        played += [child.result() for child in children]
    finally:
        for child in children:
            child.cancel()
    return played


def _camera_replays(
    f: SessionFile, names: list[str], tallies: dict[str, CameraTally]
) -> dict[str, CameraReplay]:
    """Each camera's replay with the file's own frame accounting (the recorder's drops, and
    what became of every frame the console received where the summary keeps it)."""
    drops = recording_drops(f)
    kept = ((f.summary or {}).get("extra") or {}).get("accounting") or {}
    return {
        n: CameraReplay(
            n,
            f.cameras[n].n_frames,
            tallies[n],
            drops.get(n, {}),
            FrameAccounting.from_record(kept[n]) if n in kept else None,
        )
        for n in names
    }


def _span_s(f: SessionFile, names: list[str]) -> float:
    """The longest first-to-last frame span (s) of these cameras' recorded frames."""
    span = 0
    for n in names:
        t = f.cameras[n].t_host_ns
        if len(t) > 1:
            span = max(span, int(t[-1] - t[0]))
    return span / 1e9


class _Play:
    """Some cameras' replay: their engine, built as the live console built it, and the
    timeline entries that reach it (every reading and stop event, their frames)."""

    def __init__(
        self, f: SessionFile, inputs: RecordedInputs, names: list[str], settings: dict
    ) -> None:
        self.names = names
        self.engine, self.feeder = engine_for(f, inputs, cameras=names, **settings)
        timeline = inputs.timeline
        wanted = {inputs.cameras.index(n) for n in names}
        keep = (timeline["kind"] != FRAME) | [int(c) in wanted for c in timeline["camera"]]
        self.entries = [int(k) for k in range(len(timeline)) if keep[k]]
        self.t_ns = timeline["t_ns"]

    def run(
        self,
        speed: float | None,
        t_start: float,
        progress: Callable[[int, int], None] | None,
    ) -> tuple[dict[str, CameraTally], list[StopRow]]:
        """Every entry through the engine (paced to the recorded clock at ``speed``), then
        the end of the session: what each camera's frames gave, and the stop rows."""
        feeder, entries = self.feeder, self.entries
        t0_rec = int(self.t_ns[0]) if len(self.t_ns) else 0
        for done, k in enumerate(entries, 1):
            if speed is not None:
                due = t_start + (int(self.t_ns[k]) - t0_rec) / 1e9 / speed
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)  # pacing to the recorded clock, not synchronisation
            feeder.apply(k)
            if progress is not None and (done % 500 == 0 or done == len(entries)):
                progress(done, len(entries))
        self.engine.finalize()
        return {n: feeder.tally[n] for n in self.names}, self.engine.stops()


def _may_fork(plays: list[_Play]) -> bool:
    """Whether these cameras may each play in a forked child: their engines, stop rows and
    per-frame results depend only on their own frames and on the readings and stops that every
    process applies (not so with a model, whose curves the cameras share and whose worker this
    process owns, nor when paced: the caller decides that), and a child must not read through
    the HDF5 library of its parent (:mod:`snrmon.acquisition.replay.forked`): each camera must
    be held in memory (frames memory-mapped, references read)."""
    return all(p.feeder.held_in_memory(n) for p in plays for n in p.names)


def _count_identical(rows: list[StopRow], recorded: dict[tuple[int, str], dict]) -> int:
    n = 0
    for row in rows:
        rec = recorded.get((row.stop, row.camera))
        if rec is None:
            continue
        fields: dict[str, Any] = {k: v for k, v in rec.items() if k != "model_psf"}
        nan = float("nan")
        for k in ("snr_mean", "snr_std"):
            fields[k] = nan if fields.get(k) is None else fields[k]
        fields["model_snr"] = {}
        n += row_values_equal(row, StopRow.from_fields(fields))
    return n
