"""The SNR-versus-range table, built live stop by stop (paper section 7, Figs. 7-10).

Each row is one stop and one camera: the stop's rangefinder and GPS ranges, the mean and sample
std of the peak SNR over the first 100 consecutive valid frames
(:func:`snrmon.acquisition.stops.detector.summarise_stop`), and the model's curves at that range.
Stops are found by :class:`snrmon.acquisition.stops.detector.StopDetector` (or marked by the
operator).

When a row becomes final is fixed by the data alone, never by when someone asks, so a replay of
the same frames and readings builds the same table as the live console:

- each camera's frames are offered in their own order (:meth:`StopTable.add` with a measurement,
  :meth:`StopTable.tick` without one);
- a stop's start is backdated to when the hover began, so the table keeps each camera's last
  ``history_frames`` measurements and seeds a stop's row from them when the stop appears;
- from then on the row is built as the frames come (:class:`RowBuilder`: the first ``n``
  consecutive valid frames, or the longest run);
- the row is final when its stop has ended and the camera has passed the stop's end (or at
  :meth:`StopTable.finalize`); only frames before the end count, even those that arrived before the
  end was known. ``on_final(row)`` is called once per row, on the thread of the frame that passed.
  While the model is still computing new curves for that camera (a measured sky, a PSF from the
  flight: :meth:`Predictor.pending`), the row waits for them, a frame at a time: its model values
  are then those of the inputs in force when the stop ended, not of the inputs before (a live
  recompute takes a second; a replay's is immediate, so it freezes the same row). It waits the
  same way for ``stop_model``'s values (the expected readings over the sub-pixel phases of the
  stop's own frames, :mod:`snrmon.acquisition.calibrate.stop_phases`), which the row's
  measured / expected is then of.

Until then :meth:`StopTable.rows` shows the row as it stands (provisional).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import threading
from collections import Counter, deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import InitVar, dataclass, field
from typing import Any, ClassVar, Protocol

from snrmon.acquisition.columns import MEAN, PART, column, columns_of, part
from snrmon.acquisition.measure.model_agreement import ModelAgreement, model_agreement
from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.prediction import AT_STOP, Predictor, psf_label
from snrmon.acquisition.stops.detector import Stop, is_valid, summarise_stop

Entry = tuple[int, PeakSnr]
StopModel = Callable[..., "dict[str, float] | None"]
"""``stop_model(stop, camera, range_m, run, wait=False)``: more model values for a final row
(the expected readings over its stop's phases, ``acquisition.calibrate.stop_phases``), {} for
none, None while they are being computed."""


class StopSource(Protocol):
    """Where the table takes its stops from: the live :class:`StopDetector`, or a replay's
    recorded stops. Only ``stops`` is read (stop ``i`` at index ``i``)."""

    @property
    def stops(self) -> list[Stop]: ...


@dataclass(frozen=True)
class StopPlace:
    """When and how far a stop was: its times and its ranges (a part of :class:`StopRow`)."""

    # Host monotonic clock here; a table with the session's clock gives the UTC.
    t_start_ns: int = column("stop start, UTC (session clock)", dtype="M8[ns]", name="t_start_utc")
    t_end_ns: int | None = column(
        "stop end, UTC (null: open when the file ends)", dtype="M8[ns]", name="t_end_utc"
    )
    lrf_range_m: float | None = column(
        "m, median rangefinder slant range during the stop", units="m", dtype="<f8"
    )
    gps_range_m: float | None = column(
        "m, median GPS slant range during the stop", units="m", dtype="<f8"
    )

    @property
    def range_m(self) -> float | None:
        """The stop's range: the rangefinder's when it has one, else the GPS slant range."""
        return self.lrf_range_m if self.lrf_range_m is not None else self.gps_range_m


@dataclass(frozen=True)
class StopReading:
    """What one camera measured during a stop: the peak SNR (Eq. 4) over the stop's summary
    run (:func:`snrmon.acquisition.stops.detector.summarise_stop`; a part of :class:`StopRow`)."""

    n_frames: int = column(
        "frames in the stop's summary run (first 100 consecutive valid)",
        units="frames",
        dtype="<i4",
    )
    complete: bool = column("the run has its 100 frames", dtype="?")
    snr_mean: float = column(
        "mean of the per-frame peak SNR (Eq. 4) over the run", units="1", dtype="<f8"
    )
    snr_std: float = column(
        "sample std (ddof=1) of the per-frame SNR over the run", units="1", dtype="<f8"
    )
    snr_sem: float = column(
        "snr_std / sqrt(N_eff): error of the mean, N_eff from the frames' autocorrelation "
        "(acquisition.stops.detector.mean_error)",
        default=float("nan"),
        units="1",
        dtype="<f8",
    )
    # The background(s) the summarised frames were measured against (rim, extent_rim, rect),
    # most used first, joined by "+"; "" without frames.
    background: str = column(
        "what the run's frames were measured against: rim (Eq. 4's 7x7 rim), extent_rim "
        "(outside a drone wider than the box's guard) or rect, most used first, joined by +",
        default="",
        dtype="U",
    )
    # The mean over the run of each per-frame value declared for the stop table
    # (:data:`snrmon.acquisition.columns.MEAN`), as ``<column>_mean``.
    frame_means: dict[str, float] = column(
        "the mean over the stop's run of a per-frame value (<column>_mean)",
        default_factory=dict,
        dtype="<f8",
        keyed="",
    )


@dataclass(frozen=True)
class ModelAtStop:
    """The model's values at a stop's range for one camera (paper Figs. 7-10), and the inputs
    they were computed for (a part of :class:`StopRow`; empty without a model)."""

    model_snr: dict[str, float] = column(
        "model SNR at range_m (paper Figs. 7-10), one column per curve and band edge",
        default_factory=dict,
        units="1",
        dtype="<f8",
        keyed="model_",
    )
    # The model's verdict for the small dimension at this range (None: no model).
    resolved: bool | None = column(
        "the model's verdict for the small dimension at range_m: it spans a pixel or more",
        default=None,
        dtype="?",
        name="model_resolved_small",
    )
    # The background (sky) temperature the model values were computed for (None: no model).
    model_sky_temp_k: float | None = column(
        "K, background (sky) temperature of the row's model curves",
        default=None,
        units="K",
        dtype="<f8",
    )
    # The corrected PSF the model values were computed with (a ``model.psf`` PSF, e.g. measured
    # from the flight); None: the sensor preset's (or no model).
    model_psf: object | None = field(default=None, compare=False)
    # Which PSF that is, in words (the predictor's ``curves_psf_source``: "preset: PVF 0.082
    # (sensor mwir)", "fitted: sigma 0.57 px from this flight's stops"); None: no model. Not a
    # field (read as :attr:`psf_source`): the recorded payload, the CSV and the campaign's
    # Parquet, all made of the fields, stay as they were.
    psf_source_text: InitVar[str | None] = None

    _psf_source: ClassVar[str | None] = None  # each part's own: set in __post_init__

    def __post_init__(self, psf_source_text: str | None) -> None:
        object.__setattr__(self, "_psf_source", psf_source_text)  # frozen: set once

    @property
    def psf_source(self) -> str | None:
        """Which PSF the values were computed with, in words
        (:func:`snrmon.acquisition.prediction.psf_source`); None without a model."""
        return self._psf_source


RECORDED_ORDER = (
    "camera",
    "stop",
    "manual",
    "t_start_ns",
    "t_end_ns",
    "lrf_range_m",
    "gps_range_m",
    "n_frames",
    "complete",
    "snr_mean",
    "snr_std",
    "model_snr",
    "resolved",
    "final",
    "snr_sem",
    "background",
    "model_sky_temp_k",
    "model_psf",
    "frame_means",
)
"""The order of a row's fields, its parts' among them, in every stop table and in the recorded
payload: that of the files recorded before the row was made of parts, so that their tables and
today's have their columns in one order. A field not named here follows them, in the order it is
declared."""


@dataclass(frozen=True)
class StopRow:
    """One stop and one camera of the SNR-versus-range table: which row it is, and its parts,
    the stop's times and ranges (:class:`StopPlace`), what the camera measured
    (:class:`StopReading`) and the model's values at that range (:class:`ModelAtStop`). Each of
    their fields declares the column it is in every stop table (``Session.stops()``, the
    report's CSV, the campaign's Parquet, the console), one flat table of them:
    :mod:`snrmon.acquisition.stops.columns` builds them from these declarations."""

    camera: str = column("camera name in the session", dtype="U")
    stop: int = column("stop index in the session (range-stop detector order)", dtype="<i4")
    manual: bool = column(
        "marked by the operator (the M key), not found by the detector", dtype="?"
    )
    place: StopPlace = part(StopPlace)
    reading: StopReading = part(StopReading)
    model: ModelAtStop = part(ModelAtStop, default_factory=ModelAtStop)
    # The stop ended and the camera passed its end: the row will not change.
    final: bool = column(
        "the stop ended and the camera passed its end: the row will not change",
        default=False,
        dtype="?",
    )

    _agreement: ClassVar[ModelAgreement | None] = None  # each row's own: set in __post_init__

    def __post_init__(self) -> None:
        # The mean against the model's expected reading of the row's own rule, computed here,
        # where the row is built (the processing thread), so a viewer only formats it. Not a
        # field: the row's payload (its fields) stays what the recording and the CSV hold.
        rule = self.expected_eq4_rule
        agreement = None
        if rule is not None:
            name = f"expected_eq4_{rule}"
            agreement = model_agreement(
                self.reading.snr_mean,
                self.reading.snr_sem,
                _at_stop(self.model.model_snr, name),
                name,
            )
        object.__setattr__(self, "_agreement", agreement)  # frozen: set once, at construction

    @classmethod
    def from_fields(cls, values: Mapping[str, Any], psf_source: str | None = None) -> StopRow:
        """A row from its fields by name, its parts' among them (:func:`row_fields`: a recorded
        payload); a part's field that ``values`` lacks takes its default. ``psf_source``: the
        model's PSF in words (:attr:`ModelAtStop.psf_source`, which no payload holds)."""
        parts = {}
        for f in dataclasses.fields(cls):
            inner = f.metadata.get(PART)
            if inner is not None:
                names = {g.name for g in dataclasses.fields(inner)}
                given = {k: v for k, v in values.items() if k in names}
                if inner is ModelAtStop:
                    given["psf_source_text"] = psf_source
                parts[f.name] = inner(**given)
        own = {k: v for k, v in values.items() if k in cls.__dataclass_fields__}
        return cls(**{**own, **parts})

    @property
    def agreement(self) -> ModelAgreement | None:
        """The mean against the model's expected Eq. (4) reading of the rule this row was
        measured with (:attr:`expected_eq4_rule`): ratio, band, verdict; None without a model
        or a rule."""
        return self._agreement

    @property
    def model_psf_label(self) -> str | None:
        """:attr:`ModelAtStop.psf_source` as a short mark: "preset PSF" or "fitted PSF"."""
        return psf_label(self.model.psf_source)

    @property
    def range_m(self) -> float | None:
        """The stop's range: the rangefinder's when it has one, else the GPS slant range."""
        return self.place.range_m

    @property
    def expected_eq4_rule(self) -> str | None:
        """The background rule of the expected Eq. (4) reading this row's measurement is to be
        held to (:func:`expected_eq4_rule`)."""
        return expected_eq4_rule(self.reading.background)

    @property
    def expected_eq4(self) -> float | None:
        """The model's expected Eq. (4) reading by the rule this row was measured with
        (``model_snr["expected_eq4_rim"]`` or ``["expected_eq4_extent"]``; over the stop's own
        phases, ``..._stop``, where the row has it); None without a model or a rule."""
        rule = self.expected_eq4_rule
        name = f"expected_eq4_{rule}"
        return None if rule is None else _at_stop(self.model.model_snr, name).get(name)


def row_fields(row: StopRow) -> dict[str, Any]:
    """A row's fields by name, its parts' among them, in :data:`RECORDED_ORDER` (values as
    ``dataclasses.asdict`` gives them): the flat record a recording holds of it
    (:meth:`StopRow.from_fields` reads it back)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(row):
        value = getattr(row, f.name)
        if f.metadata.get(PART) is not None:
            out.update(dataclasses.asdict(value))
        else:
            out[f.name] = copy.deepcopy(value)
    return {k: out[k] for k in recorded_order(out)}


def recorded_order(names: Iterable[str]) -> list[str]:
    """``names`` in :data:`RECORDED_ORDER`, any other after them in the order given."""
    rank = {k: i for i, k in enumerate(RECORDED_ORDER)}
    return sorted(names, key=lambda k: rank.get(k, len(rank)))  # stable: the others as given


def _at_stop(model: dict[str, float], name: str) -> dict[str, float]:
    """``model`` with the expected reading ``name`` and its band over the stop's own phases
    (``name + AT_STOP``) in place of the cell's, where it has them: what the row's measurement
    is held to (``acquisition.calibrate.stop_phases``)."""
    if f"{name}{AT_STOP}" not in model:
        return model
    out = {k: v for k, v in model.items() if k not in (f"{name}_lower", f"{name}_upper")}
    for e in ("", "_lower", "_upper"):  # the cell's band does not go with the stop's reading
        if f"{name}{AT_STOP}{e}" in model:
            out[f"{name}{e}"] = model[f"{name}{AT_STOP}{e}"]
    return out


def expected_eq4_rule(background: str) -> str | None:
    """Which expected Eq. (4) reading holds for frames measured against ``background`` (their
    methods, "+"-joined as in :attr:`StopRow.background`): ``"rim"`` when every frame used the
    paper's background, the 24 rim pixels of the 7x7 box; ``"extent"`` when any used the rim of
    the target's extent (the console departs from the paper's rim for a drone wider than the
    box's 5x5 guard, whose own light the 7x7 rim would take for sky; the extent rule of the model
    weights the two rims by the chance of that, frame by frame); None for the operator's
    clear-sky rectangle (no model of it) or no frames."""
    methods = set(background.split("+")) if background else set()
    if not methods or "rect" in methods:
        return None
    return "extent" if "extent_rim" in methods else "rim"


@dataclass(frozen=True, slots=True)
class StopProgress:
    """How far one camera's row of the latest stop is: ``n_frames`` of the ``n_wanted``
    consecutive valid frames it is summarised from (the row's own count), and whether the stop
    is still open (the drone hovering) or has ended."""

    stop: int
    manual: bool
    n_frames: int
    n_wanted: int
    complete: bool
    open: bool


def backgrounds_of(results) -> str:
    """The background methods of some measurements, most used first, joined by "+"."""
    counts = Counter(r.background for r in results)
    return "+".join(name for name, _ in counts.most_common())


def frame_means(run: Sequence[Entry]) -> dict[str, float]:
    """``{<column>_mean: mean}`` over a row's run of the per-frame values declared for the stop
    table (empty without frames)."""
    if not run:
        return {}
    record = type(run[0][1])
    return {
        f"{c.name}_mean": sum(float(getattr(r, c.field)) for _, r in run) / len(run)
        for c in columns_of(record)
        if c.stop == MEAN
    }


class RowBuilder:
    """One camera's frames during one stop, kept until the first ``n`` consecutive valid ones.

    Frames are kept as they come (whether or not the stop's end, known only later, lies before
    them); once a run of ``n`` consecutive valid frames is complete nothing more is taken, so a
    long hover costs at most ``max_frames`` entries (only a stop that never completes a run gets
    there; its oldest frames are then forgotten, the same way live and in a replay).
    """

    def __init__(self, n: int, max_frames: int = 36_000) -> None:
        self.n = n
        self.entries: deque[Entry] = deque(maxlen=max_frames)
        self._run = 0

    @property
    def filled(self) -> bool:
        return self._run >= self.n

    def add(self, t_ns: int, result: PeakSnr) -> None:
        if self.filled:
            return
        self.entries.append((t_ns, result))
        self._run = self._run + 1 if is_valid(result) else 0

    def run(self, t_end_ns: int | None) -> list[Entry]:
        """The frames the row is summarised from (:func:`summarise_stop` semantics: the first
        ``n`` consecutive valid frames, else the longest run, the earliest of equal length),
        taking only frames before ``t_end_ns`` (None: the stop is open)."""
        return run_before(list(self.entries), t_end_ns, self.n)


def run_before(entries: list[Entry], t_end_ns: int | None, n: int) -> list[Entry]:
    """:meth:`RowBuilder.run` of a copy of its entries."""
    entries = [e for e in entries if t_end_ns is None or e[0] < t_end_ns]
    summary = summarise_stop([r for _, r in entries], n)
    return entries[summary.frames]


class StopTable:
    """Collects each camera's measurements and summarises them per stop (thread-safe)."""

    def __init__(
        self,
        detector: StopSource,
        cameras: list[str],
        *,
        frames_per_stop: int = 100,
        history_frames: int = 4000,
        predictor: Predictor | None = None,
        on_final: Callable[[StopRow], None] | None = None,
        stop_model: StopModel | None = None,
    ) -> None:
        self.on_final = on_final
        self.stop_model = stop_model
        self.detector = detector
        self.cameras = list(cameras)
        self.n = frames_per_stop
        self.predictor = predictor
        self._lock = threading.RLock()
        self._recent: dict[str, deque[Entry]] = {
            c: deque(maxlen=history_frames) for c in self.cameras
        }
        self._builders: dict[tuple[int, str], RowBuilder] = {}
        self._final: dict[tuple[int, str], StopRow] = {}
        self._runs: dict[tuple[int, str], list[Entry]] = {}
        self._seen_stops = 0
        # The open rows as last shown, with what they were built from (rows()).
        self._shown: dict[tuple[int, str], tuple[tuple, StopRow]] = {}

    # ------------------------------------------------------------------ input, per camera
    def add(self, camera: str, t_host_ns: int, result: PeakSnr) -> list[StopRow]:
        """One measured frame of ``camera`` (on its measurement thread); returns the rows that
        became final on it (``on_final`` is also called for each)."""
        t = int(t_host_ns)
        with self._lock:
            self._open_new_stops()  # seeded from the history before this frame
            self._recent[camera].append((t, result))
            for (stop_index, cam), builder in self._builders.items():
                if cam != camera or (stop_index, cam) in self._final:
                    continue
                stop = self._stop(stop_index)
                if stop is not None and stop.contains(t):
                    builder.add(t, result)
            return self._finish(camera, t)

    def tick(self, camera: str, t_host_ns: int) -> list[StopRow]:
        """A frame of ``camera`` without a measurement (no ROI): it still moves the camera past
        a stop's end."""
        with self._lock:
            self._open_new_stops()
            return self._finish(camera, int(t_host_ns))

    def finalize(self) -> list[StopRow]:
        """The end of the session: every stop's rows become final as they stand."""
        with self._lock:
            self._open_new_stops()
            out = []
            for stop in self.detector.stops:
                for cam in self.cameras:
                    if (stop.index, cam) not in self._final:
                        out.append(self._freeze(stop, cam, self._stop_model(stop, cam, wait=True)))
            return out

    # ------------------------------------------------------------------ output
    def rows(self) -> list[StopRow]:
        """Every stop so far x every camera, in stop order: final rows, and the open ones as
        they stand now. An open row is summarised outside the table's lock (the measurement
        threads add to the table meanwhile), and only when its frames, its stop or the model
        changed since it was last shown."""
        todo: list[StopRow | tuple[Stop, str, list[Entry]]] = []
        with self._lock:
            self._open_new_stops()
            for stop in self.detector.stops:
                for cam in self.cameras:
                    key = (stop.index, cam)
                    final = self._final.get(key)
                    builder = self._builders.get(key)
                    if final is not None:
                        todo.append(final)
                    else:
                        todo.append((stop, cam, [] if builder is None else list(builder.entries)))
        return [item if isinstance(item, StopRow) else self._open_row(*item) for item in todo]

    def _open_row(self, stop: Stop, camera: str, entries: list[Entry]) -> StopRow:
        predictor = self.predictor
        extra = self._open_stop_model(stop, camera, entries)
        made_of = (
            stop,
            len(entries),
            entries[-1][0] if entries else None,
            id(predictor),
            getattr(predictor, "version", None),
            tuple(extra.items()),
        )
        shown = self._shown.get((stop.index, camera))
        if shown is not None and shown[0] == made_of:
            return shown[1]
        run = run_before(entries, stop.t_end_ns, self.n)
        row = self._row_of(stop, camera, run, final=False, extra=extra)
        self._shown[(stop.index, camera)] = (made_of, row)
        return row

    def progress(self, camera: str) -> StopProgress | None:
        """The latest stop's progress for ``camera`` (the open stop while the drone hovers,
        else the last one that ended); None before the first stop."""
        with self._lock:
            self._open_new_stops()
            stops = self.detector.stops
            if not stops:
                return None
            stop = stops[-1]
            key = (stop.index, camera)
            final = self._final.get(key)
            if final is not None:
                n, complete = final.reading.n_frames, final.reading.complete
            else:
                builder = self._builders.get(key)
                n = len(builder.run(stop.t_end_ns)) if builder is not None else 0
                complete = n >= self.n
            return StopProgress(stop.index, stop.manual, n, self.n, complete, stop.t_end_ns is None)

    def history(self, camera: str) -> list[Entry]:
        """The measurements of ``camera`` the table keeps to seed a backdated stop (oldest
        first): a recording that starts now records them, so its replay builds the same rows."""
        with self._lock:
            return list(self._recent[camera])

    def runs(self) -> dict[tuple[int, str], list[Entry]]:
        """``{(stop, camera): [(t_host_ns, PeakSnr), ...]}``: the frames each final row's
        statistics were taken from, in order."""
        with self._lock:
            return {k: list(v) for k, v in self._runs.items()}

    def run_of(self, stop: int, camera: str) -> list[Entry]:
        """The frames row ``(stop, camera)`` is summarised from, as of now (empty when unknown)."""
        with self._lock:
            run = self._runs.get((stop, camera))
            if run is not None:
                return list(run)
            builder = self._builders.get((stop, camera))
            match = self._stop(stop)
            if builder is None or match is None:
                return []
            return list(builder.run(match.t_end_ns))

    # ------------------------------------------------------------------ internals
    def _stop(self, index: int) -> Stop | None:
        stops = self.detector.stops
        return stops[index] if 0 <= index < len(stops) else None

    def _open_new_stops(self) -> None:
        """Seed a builder for each camera of each stop the detector found since the last call,
        from the recent history (the stop's start is backdated to when the hover began)."""
        stops = self.detector.stops
        for stop in stops[self._seen_stops :]:
            for cam in self.cameras:
                builder = RowBuilder(self.n)
                for t, result in self._recent[cam]:
                    if stop.contains(t):
                        builder.add(t, result)
                self._builders[(stop.index, cam)] = builder
        self._seen_stops = len(stops)

    def _finish(self, camera: str, t_ns: int) -> list[StopRow]:
        out = []
        for stop in self.detector.stops:
            key = (stop.index, camera)
            if key in self._final or stop.t_end_ns is None or t_ns < stop.t_end_ns:
                continue
            if self.predictor is not None and self.predictor.pending(camera):
                continue  # the model's curves for the inputs now in force: the next frame
            extra = self._stop_model(stop, camera, wait=False)
            if extra is None:
                continue  # the stop's own expected readings are being computed: the next frame
            out.append(self._freeze(stop, camera, extra))
        return out

    def _open_stop_model(self, stop: Stop, camera: str, entries: list[Entry]) -> dict[str, float]:
        """``stop_model``'s values for an open row whose run is complete (its frames will not
        change: the row shows them while the drone still hovers); {} until they are ready."""
        if self.stop_model is None or self.predictor is None or len(entries) < self.n:
            return {}
        if self.predictor.pending(camera):
            return {}  # the curves' new inputs are not theirs yet
        run = run_before(entries, stop.t_end_ns, self.n)
        if len(run) < self.n:
            return {}
        rng = stop.lrf_range_m if stop.lrf_range_m is not None else stop.gps_range_m
        return self.stop_model(stop.index, camera, rng, run, wait=False) or {}

    def _stop_model(self, stop: Stop, camera: str, *, wait: bool) -> dict[str, float] | None:
        """``stop_model``'s values for the row about to be final ({} without one)."""
        if self.stop_model is None or self.predictor is None:
            return {}
        builder = self._builders.get((stop.index, camera))
        run = builder.run(stop.t_end_ns) if builder is not None else []
        rng = stop.lrf_range_m if stop.lrf_range_m is not None else stop.gps_range_m
        got = self.stop_model(stop.index, camera, rng, run, wait=wait)
        return got if got is not None or not wait else {}

    def _freeze(self, stop: Stop, camera: str, extra: dict[str, float] | None = None) -> StopRow:
        row, run = self._row(stop, camera, final=True, extra=extra or {})
        key = (stop.index, camera)
        self._final[key] = row
        self._runs[key] = run
        self._builders.pop(key, None)
        if self.on_final is not None:
            self.on_final(row)
        return row

    def _row(
        self, stop: Stop, camera: str, *, final: bool, extra: dict[str, float]
    ) -> tuple[StopRow, list[Entry]]:
        builder = self._builders.get((stop.index, camera))
        run = builder.run(stop.t_end_ns) if builder is not None else []
        return self._row_of(stop, camera, run, final=final, extra=extra), run

    def _row_of(
        self, stop: Stop, camera: str, run: list[Entry], *, final: bool, extra=None
    ) -> StopRow:
        summary = summarise_stop([r for _, r in run], self.n)
        rng = stop.lrf_range_m if stop.lrf_range_m is not None else stop.gps_range_m
        model = dict(self.predictor(camera, rng)) if (self.predictor and rng) else {}
        if model and extra:
            model.update(extra)  # the stop's own expected readings (stop_model)
        resolved = model.pop("resolved_small", None)
        sky = self.predictor.curves_background_k.get(camera) if self.predictor and model else None
        psf = self.predictor.curves_psf.get(camera) if self.predictor and model else None
        source = self.predictor.curves_psf_source.get(camera) if self.predictor and model else None
        return StopRow(
            camera=camera,
            stop=stop.index,
            manual=stop.manual,
            place=StopPlace(stop.t_start_ns, stop.t_end_ns, stop.lrf_range_m, stop.gps_range_m),
            reading=StopReading(
                n_frames=summary.n_frames,
                complete=summary.complete,
                snr_mean=summary.snr_mean,
                snr_std=summary.snr_std,
                snr_sem=summary.snr_sem,
                background=backgrounds_of(r for _, r in run),
                frame_means=frame_means(run),
            ),
            model=ModelAtStop(
                model_snr=model,
                resolved=None if resolved is None else bool(resolved),
                model_sky_temp_k=sky,
                model_psf=psf,
                psf_source_text=source,
            ),
            final=final,
        )


def row_values_equal(a: StopRow, b: StopRow) -> bool:
    """The measured part of two rows is the same (NaN equals NaN): what a replay must reproduce."""

    def same(x, y) -> bool:
        if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
            return True
        return x == y

    compared = (
        ("", ("camera", "stop", "manual")),
        ("place", ("t_start_ns", "t_end_ns", "lrf_range_m", "gps_range_m")),
        ("reading", ("n_frames", "complete", "snr_mean", "snr_std")),
    )
    return all(
        same(getattr(getattr(a, p) if p else a, k), getattr(getattr(b, p) if p else b, k))
        for p, keys in compared
        for k in keys
    )
