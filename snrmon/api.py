"""The public face of snrmon: a few functions a scientist uses from a notebook.

Each returns labelled data (xarray, pandas) with units in its names and attributes, and each is
a thin layer over the code the console and the command line run, so a number from here is the
number the console shows. ``import snrmon`` then ``snrmon.predict(...)``; nothing here needs
Qt or Dask.

- :func:`predict`: the sensor model (paper Eqs. 1-3, Figs. 7-10) over range, as a Dataset;
- :func:`open_session`: a recorded session (:class:`RecordedSession`): frames, per-frame
  measurements, the SNR-versus-range table;
- :func:`load_stack`, :func:`measure_stack`, :func:`track_stack`: paper Eq. (4) on a stack of
  frames from a file (TIFF, raw with a JSON descriptor, video, ``.npy``) or an array.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

__all__ = [
    "RecordedSession",
    "load_stack",
    "measure_stack",
    "open_session",
    "predict",
    "track_stack",
]


# ----------------------------------------------------------------------------- the model
def predict(
    sensor: str = "mwir",
    target: str = "uav1",
    ranges_m: Sequence[float] | np.ndarray | None = None,
    **conditions: Any,
) -> xr.Dataset:
    """The model's SNR versus range for a sensor and a target (paper Eqs. 1-3, Figs. 7-10).

    Parameters
    ----------
    sensor : str
        A sensor preset (``"mwir"``, ``"lwir"``: paper Table 1) or a sensor TOML file.
    target : str
        A target preset (``"uav1"``, ``"uav2"``: paper section 3) or a target TOML file.
    ranges_m : sequence of float, optional
        Slant ranges in metres (> 0); default 500 ranges from 20 m to 5 km.
    **conditions
        The model's inputs, as :func:`snrmon.model.snr.predict` takes them: ``atmosphere``,
        ``background_temp_k`` (the measured sky), ``air_temp_k``, ``spatial_noise``,
        ``geometry`` (``"square"`` or ``"paper"``), ``corrected_psf``, ``band``,
        ``expected``, and the weather inputs where the model has them.

    Returns
    -------
    xarray.Dataset
        Coordinate ``range_m``; one variable per curve: ``small``, ``large``,
        ``small_corrected``, ``large_corrected`` (uncorrected: diffraction-limited PSF, point
        target; corrected: the real PSF and the finite target), ``expected_eq4_rim`` and
        ``expected_eq4_extent`` (what the Eq. 4 estimator should read on the small corrected
        target with the paper's 7x7 rim, and with the console's rim outside the drone's
        extent), ``paper_<curve>`` (the paper's switched curves),
        ``<curve>_lower`` / ``<curve>_upper`` (the Monte-Carlo band), ``transmission`` and
        ``resolved_small``; attributes name the sensor, target, atmosphere, temperatures and
        geometry.

    Raises
    ------
    ValueError
        An unknown preset, a range that is not positive, a condition the model refuses.

    Examples
    --------
    >>> import snrmon
    >>> ds = snrmon.predict("mwir", "uav1", [126.0, 199.0, 508.0], band=False)
    >>> ds["small_corrected"].dims
    ('range_m',)
    >>> ds.range_m.values.tolist()
    [126.0, 199.0, 508.0]
    >>> bool((ds["small"].diff("range_m") < 0).all())  # the SNR falls with range
    True
    >>> ds.attrs["sensor"], ds.attrs["target"]
    ('mwir', 'uav1')
    """
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict as model_predict

    ranges = np.geomspace(20.0, 5000.0, 500) if ranges_m is None else np.asarray(ranges_m, float)
    p = model_predict(load_sensor(sensor), load_target(target), ranges, **conditions)
    data: dict[str, Any] = {}
    for name, snr in p.curves().items():
        base, _, edge = name.rpartition("_")
        if edge in ("lower", "upper"):  # the Monte-Carlo band of the uncertain inputs (sec. 9)
            long_name = f"{edge} edge of the model's band: {_CURVE_NAMES.get(base, base)}"
        else:
            long_name = _CURVE_NAMES.get(name, name)
        data[name] = ("range_m", np.asarray(snr, float), {"units": "1", "long_name": long_name})
    data["transmission"] = (
        "range_m",
        np.asarray(p.transmission, float),
        {"units": "1", "long_name": "band transmission of the path"},
    )
    data["resolved_small"] = (
        "range_m",
        np.asarray(p.resolved_small, bool),
        {"long_name": "the small dimension spans a pixel or more"},
    )
    attrs = {
        "sensor": p.sensor_name,
        "target": p.target_name,
        "atmosphere": p.atmosphere_name,
        "background_temp_k": float(p.background_temp_k),
        "air_temp_k": float(p.air_temp_k),
        "geometry": p.geometry,
        "conditions_json": json.dumps({k: _jsonable(v) for k, v in conditions.items()}),
        "source": "snrmon.model.snr.predict (paper Eqs. 1-3, Figs. 7-10)",
    }
    coords = {"range_m": ("range_m", ranges, {"units": "m", "long_name": "slant range"})}
    return xr.Dataset(data, coords=coords, attrs=attrs)


_CURVE_NAMES = {
    "small": "SNR, small dimension, diffraction-limited PSF, point target",
    "large": "SNR, large dimension, diffraction-limited PSF, point target",
    "small_corrected": "SNR, small dimension, real PSF and finite target",
    "large_corrected": "SNR, large dimension, real PSF and finite target",
    "expected_eq4_rim": "what Eq. (4) is expected to read with the paper's 7x7 box rim",
    "expected_eq4_extent": "what Eq. (4) is expected to read with the console's target-aware rim",
}


def _jsonable(value: Any) -> Any:
    return value if isinstance(value, (str, int, float, bool, type(None))) else repr(value)


def __getattr__(name: str) -> Any:
    """``Session``: the old name of :class:`RecordedSession`, kept for scripts that use it (a
    DeprecationWarning; the live session is ``snrmon.acquisition.runtime.session.Session``)."""
    if name == "Session":
        warnings.warn(
            "snrmon.Session is now snrmon.RecordedSession (a recorded file); the old name goes "
            "in a later release",
            DeprecationWarning,
            stacklevel=2,
        )
        return RecordedSession
    raise AttributeError(f"module 'snrmon.api' has no attribute {name!r}")


# ----------------------------------------------------------------------------- sessions
class RecordedSession:
    """A recorded session file, opened read-only (:func:`open_session`).

    Named ``Session`` before: that name still works, with a DeprecationWarning.

    Parameters
    ----------
    path : str or os.PathLike
        The session's HDF5 file (``snrmon record``, the console, ``snrmon hil --out``).

    Attributes
    ----------
    path : pathlib.Path
    cameras : tuple of str
        The cameras the file holds.
    config : dict
        The session's configuration as recorded.
    format_version : str
    """

    def __init__(self, path: str | Path) -> None:
        from snrmon.acquisition.record.reader import open_session as read
        from snrmon.inputs import is_hdf5

        self.path = Path(path)
        if self.path.is_dir():
            raise IsADirectoryError(f"{self.path} is a folder, not a session file")
        if self.path.is_file() and not is_hdf5(self.path):
            raise ValueError(f"{self.path} is not a snrmon session file (not HDF5)")
        with read(self.path) as f:
            self.cameras: tuple[str, ...] = tuple(f.cameras)
            self.config: dict = f.config
            self.format_version: str = f.format_version
            self._rows = {name: cam.measurements for name, cam in f.cameras.items()}
            self._frames = {name: cam.n_frames for name, cam in f.cameras.items()}
            self._clock = f.clock
            self._events = f.event_list()
            self._complete = f.complete
        self._replay: dict[bool, Any] = {}
        self._stops: dict[bool, pd.DataFrame] = {}
        self._open: list[xr.Dataset] = []  # what to_xarray opened: close() closes them

    def __repr__(self) -> str:
        frames = ", ".join(f"{c} {self._frames[c]} frames" for c in self.cameras)
        return f"<snrmon.RecordedSession {self.path.name}: {frames}; format {self.format_version}>"

    def __enter__(self) -> RecordedSession:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the file at once.

        The Datasets and DataArrays :meth:`to_xarray` and :meth:`frames` gave are closed (read
        what you need from them first), and the cached replay and tables are dropped. The file
        then opens anywhere, in any mode.
        """
        for ds in self._open:
            ds.close()
        self._open.clear()
        self._replay.clear()
        self._stops.clear()

    def _camera(self, camera: str) -> str:
        if camera not in self.cameras:
            known = ", ".join(self.cameras) or "none"
            raise ValueError(f"{self.path.name} has no camera {camera!r} (it holds {known})")
        return camera

    def to_xarray(self, camera: str) -> xr.Dataset:
        """The camera's group as a lazily read Dataset.

        ``frames (time, row, col)`` in DN with the frames' UTC as the ``time`` coordinate, the
        per-frame counters and times, the recorded measurements and background references
        (format 2.2; older files get the same names). It stays open until :meth:`close`.

        Parameters
        ----------
        camera : str
            One of :attr:`cameras`.

        Returns
        -------
        xarray.Dataset
            The camera's group, read as it is accessed.

        Raises
        ------
        ValueError
            The file holds no such camera.

        Examples
        --------
        >>> import tempfile, pathlib, snrmon
        >>> from snrmon.examples import example_session
        >>> path = example_session(pathlib.Path(tempfile.mkdtemp()) / "s.h5", hover_s=2.0).path
        >>> ds = snrmon.open_session(path).to_xarray("mwir")
        >>> ds["frames"].dims, ds["frames"].shape
        (('time', 'row', 'col'), (200, 40, 56))
        >>> str(ds["time"].dtype)
        'datetime64[ns]'
        """
        from snrmon.acquisition.compression import register_filters

        self._camera(camera)
        register_filters()  # compressed frames read like raw ones
        # h5py's default locking, as the reader's: the file opens again alongside
        ds = xr.open_dataset(self.path, group=f"cameras/{camera}", engine="h5netcdf")
        self._open.append(ds)
        if "time" in ds.dims:
            return ds
        return _named_axes(ds)  # a file from before format 2.2

    def frames(self, camera: str) -> xr.DataArray:
        """The camera's frames, lazily read.

        Parameters
        ----------
        camera : str
            One of :attr:`cameras`.

        Returns
        -------
        xarray.DataArray
            ``frames (time, row, col)`` in DN, the frames' UTC as ``time`` (see
            :meth:`to_xarray`); readable until :meth:`close`.
        """
        return self.to_xarray(camera)["frames"]

    def measurements(self, camera: str) -> pd.DataFrame:
        """One row per measured frame of ``camera``: paper Eq. (4) as the live console measured it.

        A file that holds frames but no measurements (recorded without a click) is measured
        again through the live engine first.

        Parameters
        ----------
        camera : str
            One of :attr:`cameras`.

        Returns
        -------
        pandas.DataFrame
            Peak position and value, background mean and std, SNR, its flags as boolean
            columns, the background rule, the track state, the running statistics, the
            range; ``utc`` a timestamp; the columns' units in ``attrs["units"]``.

        Examples
        --------
        >>> import tempfile, pathlib, snrmon
        >>> from snrmon.examples import example_session
        >>> path = example_session(pathlib.Path(tempfile.mkdtemp()) / "s.h5", hover_s=2.0).path
        >>> m = snrmon.open_session(path).measurements("mwir")
        >>> len(m), m["track_state"].iloc[0], str(m["utc"].dtype)
        (200, 'tracking', 'datetime64[ns, UTC]')
        >>> bool((m["peak_x"].iloc[:40] == 30).all())  # the spot, at the first stop
        True
        """
        from snrmon.acquisition.record.stream_rows import measurement_row

        rows = self._rows[self._camera(camera)]
        if len(rows) == 0 and self._frames[camera] > 0:
            from snrmon.acquisition.record import schema

            done = self.replay().cameras[camera].tally.measurements
            rows = np.array(
                [measurement_row(None, m) for m in done], dtype=schema.MEASUREMENT_DTYPE
            )
        frame = _measurement_frame(rows, self._clock)
        frame.attrs["units"] = _measurement_units(frame)
        return frame

    def stops(self, *, model: bool = True) -> pd.DataFrame:
        """The SNR-versus-range table: one row per stop and camera, as the live console built it.

        The rows the console recorded when the recording stopped (``stop_summary`` events),
        which a replay through the same engine reproduces; a file without them (a crash, a
        format 1 file) or, with ``model``, without the model's values (recorded with no model)
        is replayed (:meth:`replay`), with the model's curves for the recorded sensor presets
        and target. Cached per ``model``.

        Parameters
        ----------
        model : bool, default True
            Include the model's values at each stop's range (``model_<curve>`` columns and
            ``model_sky_temp_k``).

        Returns
        -------
        pandas.DataFrame
            The columns of every stop table (the report's CSV, the campaign's Parquet, the
            console: :func:`snrmon.acquisition.stops.columns.stop_columns`): ``camera``,
            ``stop``, ``manual``, the stop's times (``t_start_utc``, ``t_end_utc``),
            ``range_m`` (the rangefinder's, else the GPS slant range), ``lrf_range_m``,
            ``gps_range_m``, ``n_frames``, ``complete``, ``snr_mean``, ``snr_std``,
            ``snr_sem``, ``background``, ``final``, and with ``model`` the model's values
            (``model_<curve>``, their band ``model_<curve>_lower`` / ``_upper``,
            ``model_resolved_small``, ``model_sky_temp_k``); the columns' units in
            ``attrs["units"]``.

        Examples
        --------
        >>> import tempfile, pathlib, snrmon
        >>> from snrmon.examples import example_session
        >>> path = example_session(pathlib.Path(tempfile.mkdtemp()) / "s.h5", hover_s=8.0).path
        >>> t = snrmon.open_session(path).stops(model=False)
        >>> print(t[["camera", "stop", "range_m", "n_frames"]].to_string(index=False))
        camera  stop  range_m  n_frames
          lwir     0    120.0       100
          lwir     1    240.0       100
          mwir     0    120.0       100
          mwir     1    240.0       100
        >>> bool((t["snr_mean"].iloc[0] > t["snr_mean"].iloc[1]))  # farther, fainter
        True
        """
        if model in self._stops:
            return self._stops[model].copy()
        rows = self._recorded_rows(model)
        if rows is None:
            rows = self.replay(model=model).stops
        from snrmon.acquisition.stops.columns import stop_record, stop_units

        def utc(t_host_ns: int) -> pd.Timestamp | None:
            return _utc(t_host_ns, self._clock)

        records = []
        for r in rows:
            rec = stop_record(r, utc=utc, keys=None if model else {"model_snr": ()})
            rec["range_m"] = _round_range(r.range_m)
            if not model:
                del rec["model_sky_temp_k"], rec["model_resolved_small"]
            elif rec["model_sky_temp_k"] is None:
                del rec["model_sky_temp_k"]
            records.append(rec)
        frame = pd.DataFrame.from_records(records)
        if not frame.empty:
            frame = frame.sort_values(["camera", "stop"], ignore_index=True)
        frame.attrs["units"] = stop_units(frame.columns)
        self._stops[model] = frame
        return frame.copy()

    def _recorded_rows(self, model: bool) -> list | None:
        """The stop table the live console recorded at the end (the last ``stop_summary`` of
        each stop and camera), as rows; None when the file was not stopped cleanly, holds no
        rows, or (with ``model``) holds rows without the model's values."""
        from snrmon.acquisition.stops.table import StopRow

        if not self._complete:
            return None
        last: dict[tuple[int, str], dict] = {}
        for e in self._events:
            if e["kind"] == "stop_summary" and "t_start_ns" in e["payload"]:
                last[(int(e["payload"]["stop"]), e["camera"])] = e["payload"]
        if not last or (model and not all(p.get("model_snr") for p in last.values())):
            return None
        rows = []
        for p in last.values():
            values = {k: v for k, v in p.items() if k != "model_psf"}
            for k in ("snr_mean", "snr_std", "snr_sem"):  # recorded null: not finite
                values[k] = math.nan if values.get(k) is None else values[k]
            for k in ("model_snr", "frame_means"):  # recorded null: not finite
                values[k] = {n: (math.nan if v is None else v) for n, v in (p.get(k) or {}).items()}
            rows.append(StopRow.from_fields(values))
        return rows

    def replay(self, *, model: bool = True) -> Any:
        """The whole recording through the live engine, once per ``model``.

        :func:`snrmon.acquisition.replay.batch.replay_session`, fast: only the pixels the
        measurement reads.

        Parameters
        ----------
        model : bool, default True
            Give the stop table the model's curves (the recorded sensor presets and target).

        Returns
        -------
        snrmon.acquisition.replay.batch.ReplayResult
            The replay's stop table (``.stops``), per-camera tallies and timing.
        """
        from snrmon.acquisition.replay.batch import replay_session

        if model not in self._replay:  # one per argument: a model-free table has no model columns
            predictor = self._predictor() if model else None
            self._replay[model] = replay_session(self.path, fast=True, predictor=predictor)
        return self._replay[model]

    def _predictor(self) -> Any:
        from snrmon.acquisition.prediction import ModelPredictor

        session = self.config.get("session") or {}
        cameras = session.get("cameras") or {}
        sensors = {c: str((cameras.get(c) or {}).get("sensor", c)) for c in self.cameras}
        try:
            return ModelPredictor(sensors, str(session.get("target", "uav1")))
        except ValueError:  # a camera without a known sensor preset: no model column
            return None


def open_session(path: str | Path) -> RecordedSession:
    """Open a recorded session (HDF5, any format version) for reading.

    Parameters
    ----------
    path : str or os.PathLike
        The session's HDF5 file (``snrmon record``, the console, ``snrmon hil --out``).

    Returns
    -------
    RecordedSession
        ``.frames(camera)``, ``.measurements(camera)``, ``.stops()``, ``.to_xarray(camera)``.

    Raises
    ------
    FileNotFoundError
        No such file.
    IsADirectoryError
        ``path`` is a folder.
    ValueError
        The file is not a snrmon session (not HDF5, or HDF5 without the session's ``format``).

    Notes
    -----
    The file is opened read-only with h5py's and xarray's default file locking, so
    ``h5py.File(path, "r")`` and ``xarray.open_dataset(path, ...)`` open it alongside in the same
    process; :meth:`RecordedSession.close` (or the end of a ``with`` block) closes what the session
    opened at once.

    Examples
    --------
    >>> import tempfile, pathlib, snrmon
    >>> from snrmon.examples import example_session
    >>> path = example_session(pathlib.Path(tempfile.mkdtemp()) / "s.h5", hover_s=2.0).path
    >>> s = snrmon.open_session(path)
    >>> s.cameras
    ('lwir', 'mwir')
    """
    return RecordedSession(path)


def _measurement_units(frame: pd.DataFrame) -> dict[str, str]:
    """``{column: units}`` of a measurement table's columns that have one (DN: the camera's raw
    counts), as the session file's columns declare them; in ``df.attrs["units"]``."""
    from snrmon.acquisition.columns import units_of
    from snrmon.acquisition.record.schema import MEASUREMENT_COLUMNS

    units = units_of(MEASUREMENT_COLUMNS)
    return {c: units[c] for c in frame.columns if c in units}


def _named_axes(ds: xr.Dataset) -> xr.Dataset:
    """A camera group written before format 2.2 (phony dimensions) with the 2.2 names."""
    frames = ds["frames"]
    n = min(frames.shape[0], *(ds[v].shape[0] for v in ("counter", "t_host_ns", "utc_ns")))
    utc = pd.to_datetime(np.asarray(ds["utc_ns"].values[:n], np.int64))
    data = frames.variable.data[:n]
    return xr.Dataset(
        {"frames": (("time", "row", "col"), data, frames.attrs)}, coords={"time": utc}
    )


def _utc(t_host_ns: int | None, clock: np.ndarray) -> pd.Timestamp | None:
    from snrmon.acquisition.record.gps_align import host_to_utc_ns

    if t_host_ns is None:
        return None
    return pd.Timestamp(int(host_to_utc_ns(np.array([t_host_ns]), clock)[0]), unit="ns", tz="UTC")


def _round_range(r: float | None) -> float | None:
    return None if r is None else float(round(r, 1))


def _measurement_frame(rows: np.ndarray, clock: np.ndarray) -> pd.DataFrame:
    """Measurement rows (the file's compound dtype) as a DataFrame: strings decoded, flags as
    boolean columns, NaN-marked missing values as NA, ``utc`` a timestamp."""
    from snrmon.acquisition.record.gps_align import host_to_utc_ns

    frame = pd.DataFrame({name: rows[name] for name in rows.dtype.names})
    for name in rows.dtype.names:
        if rows.dtype[name].kind == "S":
            frame[name] = [v.decode("utf-8", errors="replace") for v in rows[name]]
    _add_flag_columns(frame, rows["flags"])
    frame = frame.drop(columns=["flags"])
    frame["frame_index"] = frame["frame_index"].astype("Int64").where(frame["frame_index"] >= 0)
    utc = host_to_utc_ns(np.asarray(rows["t_host_ns"], np.int64), clock) if len(rows) else []
    frame.insert(3, "utc", pd.to_datetime(np.asarray(utc, np.int64), unit="ns", utc=True))
    return frame


def _add_flag_columns(frame: pd.DataFrame, bits: np.ndarray) -> None:
    """One boolean column per Eq. (4) flag (``flag_saturated`` ...) from the flag bit masks
    (bit i is ``FLAG_NAMES[i]``)."""
    from snrmon.acquisition.measure.peak_snr import FLAG_NAMES

    mask = np.asarray(bits, np.int64)
    for i, flag in enumerate(FLAG_NAMES):
        frame[f"flag_{flag}"] = (mask >> i) & 1 == 1


# ----------------------------------------------------------------------------- stacks
STACK_UNITS = ("counts", "radiance", "temperature_c")


def load_stack(path: str | Path, units: str = "counts") -> xr.DataArray:
    """The frames of a stack file as a DataArray ``(frame, row, col)``.

    Memory-mapped where the format allows.

    Parameters
    ----------
    path : str or os.PathLike
        ``.npy`` (N, H, W) or (H, W); a multi-page TIFF; PNG; a raw file with ``FILE.json``
        beside it (``{"shape": [N, H, W], "dtype": "<u2"}``); a video (8-bit grey); a
        Cedip/Altair ``.ptw`` radiometric recording; a FLIR ``.seq``, ``.csq``, ``.fff`` or
        radiometric ``.jpg``; and every other format
        :mod:`snrmon.acquisition.replay.stack_io` reads (docs/camera-files.md).
    units : {"counts", "radiance", "temperature_c"}
        ``counts``: the pixels as the file stores them. For a file that carries its camera's
        radiometric calibration (FLIR): ``radiance``, the object signal in the camera's
        radiometric unit (the count a blackbody at the object's temperature would give at
        emissivity 1 through a transparent path), and ``temperature_c``, the object
        temperature [degC] by FLIR's raw-to-temperature relation with the file's emissivity,
        reflected and atmospheric temperatures, humidity and distance
        (docs/measurement.md, "FLIR raw counts to temperature"). Both are float64 arrays
        in memory (8 bytes a pixel), where counts stay memory-mapped.

    Returns
    -------
    xarray.DataArray
        Dimensions ``frame``, ``row``, ``col``; a ``time`` coordinate on ``frame`` (UTC,
        datetime64[ns]) where the file stores each frame's time; attributes ``source`` (the
        path), ``units`` (``DN``, ``DN (object signal)`` or ``degC``), what the file says of
        its camera (``.ptw``: ``camera``, ``lens``, ``filter``, ``integration_time_s``,
        ``frame_period_s``; FLIR: ``camera``, ``serial_number``, ``lens``, ``frame_rate_hz``,
        ``utc_offset_min``) and a FLIR file's calibration (``planck_r1``, ``planck_r2``,
        ``planck_b``, ``planck_f``, ``planck_o``, ``emissivity``, ``object_distance_m``,
        ``reflected_temp_k``, ``atmospheric_temp_k``, ``ir_window_temp_k``,
        ``ir_window_transmission``, ``relative_humidity`` (a ratio), ``atm_trans_alpha1``,
        ``atm_trans_alpha2``, ``atm_trans_beta1``, ``atm_trans_beta2``, ``atm_trans_x``).

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np, snrmon
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "stack.npy"
    >>> np.save(path, np.zeros((5, 16, 20), np.uint16))
    >>> snrmon.load_stack(path).sizes
    Frozen({'frame': 5, 'row': 16, 'col': 20})
    """
    from snrmon.acquisition.replay.stack_io import read_stack

    if units not in STACK_UNITS:
        raise ValueError(f"units must be one of {', '.join(STACK_UNITS)}; got {units!r}")
    stack = read_stack(path)
    attrs: dict[str, Any] = {"source": str(path), "units": "DN", **stack.attrs}
    data: np.ndarray = stack.frames
    if stack.radiometry is not None:
        attrs |= stack.radiometry.attrs()
    if units != "counts":
        if stack.radiometry is None:
            raise ValueError(
                f"{path}: units={units!r} needs the camera's radiometric calibration, which "
                "this file does not carry (a FLIR .seq/.csq/.fff/.jpg does); only counts"
            )
        if units == "radiance":
            data, attrs["units"] = stack.radiometry.object_signal(data), "DN (object signal)"
        else:
            data, attrs["units"] = stack.radiometry.temperature_c(data), "degC"
    coords = {} if stack.utc is None else {"time": ("frame", stack.utc)}
    return xr.DataArray(
        data, dims=("frame", "row", "col"), coords=coords, attrs=attrs, name="frames"
    )


def measure_stack(
    stack: xr.DataArray | np.ndarray | str | Path,
    at: tuple[float, float],
    *,
    search_px: int = 11,
    box_px: int = 7,
    background: tuple[int, int, int, int] | None = None,
    detrend: bool = False,
    window: int = 100,
    track: bool = False,
) -> pd.DataFrame:
    """Paper Eq. (4) on every frame of a stack, at a point or following the object there.

    At the operator's point (``track=False``) or following the object clicked there
    (``track=True``, :func:`track_stack`).

    Per frame: the brightest pixel in the ``search_px`` window centred on ``at``; the
    ``box_px`` box centred on it; SNR = (peak - mean(rim)) / std(rim) with the sample std
    (ddof 1) of the box's rim (or of the clear-sky rectangle ``background`` = (x0, y0, x1,
    y1), corners included), detrended by a plane when asked.

    Parameters
    ----------
    stack : xarray.DataArray, numpy.ndarray or str or os.PathLike
        The frames (frames, rows, columns), or a stack file :func:`load_stack` reads.
    at : (float, float)
        Column and row of the operator's point (zero-based).
    search_px, box_px : int
        Odd sizes of the search window and the box (11, 7: the paper's).
    background : (int, int, int, int), optional
        A clear-sky rectangle (x0, y0, x1, y1), corners included, for the background instead
        of the box's rim.
    detrend : bool
        Remove a fitted plane from the background pixels before their mean and std.
    window : int
        Frames in the running statistics (``snr_mean``, ``snr_std``: the paper's 100).
    track : bool
        Follow the object clicked at ``at`` (:func:`track_stack`) instead of a fixed point.

    Returns
    -------
    pandas.DataFrame
        One row per frame, by the session file's names for the Eq. (4) result: ``peak_x``,
        ``peak_y``, ``peak`` (DN), ``bg_mean``, ``bg_std`` (DN), ``snr``, ``background``
        (which pixels: ``rim``, ``extent_rim``, ``rect``), one boolean column per flag
        (``flag_saturated`` ...); with ``track`` those of :func:`track_stack`; the columns'
        units in ``attrs["units"]``.

    Examples
    --------
    >>> import numpy as np, snrmon
    >>> rng = np.random.default_rng(0)
    >>> frames = rng.normal(1000.0, 5.0, (50, 40, 40))
    >>> frames[:, 20, 18] += 100.0  # a 20-sigma point
    >>> m = snrmon.measure_stack(frames, at=(18, 20))
    >>> bool((m["peak_x"] == 18).all()), bool(15 < m["snr"].median() < 25)
    (True, True)
    """
    from snrmon.acquisition.measure.stack_snr import measure_stack as measure

    pixels = _pixels(stack)
    config = {
        "search_px": search_px,
        "box_px": box_px,
        "background": background,
        "detrend": detrend,
    }
    if track:
        return track_stack(pixels, at, **config)
    result = measure(pixels, at, window=window, **config)
    # the declared columns the vectorised path holds, as it holds them (an array per column)
    arrays = {f.name: getattr(result, f.name) for f in dataclasses.fields(result)}
    return _peak_snr_frame(None, len(result), arrays, result.flag_bits)


def track_stack(
    stack: xr.DataArray | np.ndarray | str | Path,
    at: tuple[float, float],
    *,
    search_px: int = 11,
    box_px: int = 7,
    background: tuple[int, int, int, int] | None = None,
    detrend: bool = False,
) -> pd.DataFrame:
    """Follow the object clicked at ``at`` through a stack and measure it every frame.

    The console's tracker (docs/tracking.md), against the background its extent allows.

    Parameters
    ----------
    stack : xarray.DataArray, numpy.ndarray or str or os.PathLike
        The frames (frames, rows, columns), or a stack file :func:`load_stack` reads.
    at : (float, float)
        Column and row of the object at the first frame (zero-based).
    search_px, box_px : int
        Odd sizes of the search window and the box (11, 7: the paper's).
    background : (int, int, int, int), optional
        A clear-sky rectangle (x0, y0, x1, y1), corners included, for the background.
    detrend : bool
        Remove a fitted plane from the background pixels before their mean and std.

    Returns
    -------
    pandas.DataFrame
        The columns of :func:`measure_stack` (with the target's segmented extent,
        ``extent_w_px``, ``extent_h_px``), plus ``track_state`` (``tracking``, ``lost``,
        ``reacquiring`` ...), ``track_reason`` (why the object was not found, empty when it
        was), ``window_x`` and ``window_y``; the columns' units in ``attrs["units"]``.

    Examples
    --------
    >>> import numpy as np, snrmon
    >>> rng = np.random.default_rng(1)
    >>> frames = rng.normal(1000.0, 5.0, (30, 60, 60))
    >>> for i, f in enumerate(frames):
    ...     f[30, 10 + i] += 120.0  # a point drifting one column a frame
    >>> t = snrmon.track_stack(frames, at=(10, 30))
    >>> t["peak_x"].tolist()[-1], t["track_state"].iloc[-1]
    (39, 'tracking')
    """
    from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
    from snrmon.acquisition.track.tracker import track_stack as track

    pixels = _pixels(stack)
    config = PeakSnrConfig(
        search_px=search_px, box_px=box_px, background=background, detrend=detrend
    )
    steps = track(pixels, at, measurement=config)
    frame = _peak_snr_frame(lambda: [s.peak_snr for s in steps], len(steps))
    frame["track_state"] = [s.state.value for s in steps]
    frame["track_reason"] = [s.reason for s in steps]
    frame["window_x"] = np.array([s.window_x for s in steps], np.int32)
    frame["window_y"] = np.array([s.window_y for s in steps], np.int32)
    frame.attrs["units"] |= {"window_x": "px", "window_y": "px"}
    return frame


def _peak_snr_frame(
    results: Callable[[], Sequence[Any]] | None,
    n: int,
    arrays: dict[str, Any] | None = None,
    flag_bits: np.ndarray | None = None,
) -> pd.DataFrame:
    """``n`` Eq. (4) results as a DataFrame, one row per frame: a column per field the result
    declares (as the session file holds them), its flags as boolean columns (``flag_<name>``),
    the columns' units in ``attrs["units"]``. ``arrays``: columns already at hand by field
    (an array, or one value for every frame), ``flag_bits`` the flags' bit masks; the rest
    from ``results()``, the per-frame results (None: only the columns at hand)."""
    from snrmon.acquisition.columns import units_of
    from snrmon.acquisition.measure.peak_snr import flags_to_bits
    from snrmon.acquisition.record.schema import PEAK_SNR_COLUMNS

    arrays = arrays or {}
    records: Sequence[Any] | None = None
    data: dict[str, Any] = {}
    for c in PEAK_SNR_COLUMNS:
        if c.name == "flags":
            continue  # as one boolean column per flag
        if c.field in arrays:
            values = arrays[c.field]
            values = values if isinstance(values, np.ndarray) else [values] * n
        elif results is None:
            continue
        else:
            records = results() if records is None else records
            values = [getattr(r, c.field) for r in records]
        data[c.name] = values if c.dtype.startswith("S") else np.asarray(values, c.dtype)
    frame = pd.DataFrame(data, index=pd.RangeIndex(n, name="frame"))
    if flag_bits is None:
        records = (results() if results else []) if records is None else records
        flag_bits = np.array([flags_to_bits(r.flags) for r in records], np.int64)
    _add_flag_columns(frame, flag_bits)
    frame.attrs["units"] = {k: v for k, v in units_of(PEAK_SNR_COLUMNS).items() if k in frame}
    return frame


def _pixels(stack: xr.DataArray | np.ndarray | str | Path) -> np.ndarray:
    if isinstance(stack, (str, Path)):
        return load_stack(stack).values
    array = stack.values if isinstance(stack, xr.DataArray) else np.asarray(stack)
    if array.ndim == 2:
        array = array[None]
    if array.ndim != 3:
        raise ValueError(f"a stack must be 3-D (frames, rows, columns), got shape {array.shape}")
    if not math.prod(array.shape):
        raise ValueError(f"the stack is empty (shape {array.shape})")
    return array
