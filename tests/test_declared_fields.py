"""Each record's fields declared once: a field added to :class:`PeakSnr` reaches the session file,
the API's tables, the campaign's tables and the console's stop table with that one edit.

The edit is a subclass with one more declared field (the peak's contrast over the background
mean, which the stop table carries the mean of) put in place of ``PeakSnr`` before any other
module of snrmon is imported, as the edited source would be: in a fresh interpreter, so the
rest of the test suite sees the class as it is. The session is recorded live by ``snrmon hil``
(the digital twin through the real pipeline and recorder), then read back by every consumer.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

SCRIPT = textwrap.dedent(
    """
    import dataclasses, json, math, sys

    from snrmon.acquisition.columns import MEAN, column
    from snrmon.acquisition.measure import peak_snr

    @dataclasses.dataclass(frozen=True, slots=True)
    class PeakSnr(peak_snr.PeakSnr):
        contrast_dn: float = column(
            "DN, the peak above the background mean",
            default=math.nan,
            units="DN",
            cf_units="1",
            dtype="<f8",
            stop=MEAN,
        )

        def __post_init__(self):
            object.__setattr__(self, "contrast_dn", self.peak - self.bg_mean)

    peak_snr.PeakSnr = PeakSnr  # the one edit, before anything else imports the record

    import h5py
    import numpy as np

    import snrmon
    from snrmon.acquisition.report.stop_csv import CSV_COLUMNS, csv_rows
    from snrmon.campaign.settings import AnalysisSettings
    from snrmon.campaign.tables import frame_table, stop_table
    from snrmon.campaign.tasks import analyse_camera
    from snrmon.cli import main
    from snrmon.gui.stop_table_view import columns, row_texts

    path = sys.argv[1]
    argv = ["hil", "--out", path, "--stops", "37,126", "--hover-s", "4", "--speed", "4"]
    argv += ["--cameras", "lwir", "--seed", "0", "--size", "256x192", "--json", "--quiet"]
    assert main(argv) == 0
    out = {}
    with h5py.File(path, "r") as f:
        m = f["cameras/lwir/measurements"]
        column = m["contrast_dn"]
        contrast = m["peak"][()] - m["bg_mean"][()]
        out["file"] = {
            "units": column.attrs["units"],
            "long_name": column.attrs["long_name"],
            "units_json": json.loads(m.attrs["units_json"])["contrast_dn"],
            "rows": int(column.shape[0]),
            "max_error": float(np.nanmax(np.abs(column[()] - contrast))),
            "finite": int(np.isfinite(column[()]).sum()),
        }
    with snrmon.open_session(path) as s:
        frame = s.measurements("lwir")
        stops = s.stops()
        replayed = s.replay().stops
    error = frame["contrast_dn"] - (frame["peak"] - frame["bg_mean"])
    out["measurements"] = {
        "units": frame.attrs["units"]["contrast_dn"],
        "max_error": float(np.nanmax(np.abs(error))),
    }
    out["stops"] = {
        "units": stops.attrs["units"]["contrast_dn_mean"],
        "values": stops["contrast_dn_mean"].tolist(),
    }
    out["csv"] = {
        "in_header": "contrast_dn_mean" in CSV_COLUMNS,
        "values": [r["contrast_dn_mean"] for r in csv_rows(replayed)],
    }
    task = analyse_camera(path, "lwir", AnalysisSettings(), frames=True)
    frames = frame_table([task.frames])
    table = stop_table(task.stops)
    peak = np.asarray(frames.column("peak").to_numpy(zero_copy_only=False), float)
    bg = np.asarray(frames.column("bg_mean").to_numpy(zero_copy_only=False), float)
    contrast = np.asarray(frames.column("contrast_dn").to_numpy(zero_copy_only=False), float)
    out["campaign"] = {
        "frame_max_error": float(np.nanmax(np.abs(contrast - (peak - bg)))),
        "stop_values": table.column("contrast_dn_mean").to_pylist(),
    }
    rows = [r for r in replayed if r.reading.n_frames]
    cells = [dict(zip([c.key for c in columns([r])], row_texts(r))) for r in rows]
    out["console"] = {
        "cells": [c["contrast_dn_mean"] for c in cells],
        "means": [r.reading.frame_means["contrast_dn_mean"] for r in rows],
        "title": [c.title for c in columns(rows) if c.key == "contrast_dn_mean"],
    }
    print(json.dumps(out))
    """
)


@pytest.mark.slow
def test_a_field_added_to_peak_snr_reaches_every_table(tmp_path):
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen"}
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(tmp_path / "s.h5")],
        capture_output=True,
        text=True,
        env=env,
        cwd=Path(__file__).resolve().parents[1],
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    # the session file: a column of its own, with its units and meaning, the value per frame
    f = out["file"]
    assert f["units"] == "1" and f["units_json"] == "DN, the peak above the background mean"
    assert f["long_name"] == "contrast_dn: DN, the peak above the background mean"
    assert f["rows"] > 100 and f["finite"] > 100 and f["max_error"] == 0.0
    # the API: the measurement table's column and units; the stop table's mean and units
    assert out["measurements"] == {"units": "DN", "max_error": 0.0}
    assert out["stops"]["units"] == "DN"
    recorded = [v for v in out["stops"]["values"] if v == v]  # NaN: a stop without frames
    assert len(recorded) >= 2 and all(v > 0 for v in recorded)  # the drone above the sky
    # the report's CSV: the same column, the same values as the replay's rows
    assert out["csv"]["in_header"]
    assert [v for v in out["csv"]["values"] if v is not None] == pytest.approx(recorded)
    # the campaign: the per-frame column and the stop table's mean, in their Parquet schemas
    assert out["campaign"]["frame_max_error"] == 0.0
    assert [v for v in out["campaign"]["stop_values"] if v is not None] == pytest.approx(recorded)
    # the console's stop table: a column of its own, each row's mean as its cell
    console = out["console"]
    assert console["title"] == ["contrast dn mean\n(DN)"]
    assert console["cells"] == [f"{v:.2f}" for v in console["means"]]
    assert console["means"] == pytest.approx(recorded)


def test_a_column_a_file_lacks_reads_as_its_fields_default(tmp_path):
    """A measurements group written before some of the declared columns existed (here only the
    1.x columns): the Eq. (4) columns it lacks read as their fields' defaults."""
    import h5py
    import numpy as np

    from snrmon.acquisition.measure.peak_snr import PeakSnr
    from snrmon.acquisition.record import schema
    from snrmon.acquisition.record.reader import measurement_rows
    from snrmon.acquisition.record.stream_rows import peak_snr_from_row

    with h5py.File(tmp_path / "old.h5", "w") as f:
        g = f.create_group(schema.MEASUREMENTS)
        for name in schema.MEASUREMENT_FIELDS_V1:
            values = np.arange(3).astype(schema.MEASUREMENT_DTYPE[name])
            g.create_dataset(name, data=values)
        rows = measurement_rows(g)
    assert rows["background"].tolist() == [b"rim"] * 3
    assert rows["extent_w_px"].tolist() == rows["extent_h_px"].tolist() == [0, 0, 0]
    read = peak_snr_from_row(rows[2])
    assert read == PeakSnr(2, 2, 2.0, 2.0, 2.0, 2.0, frozenset({"edge"}))  # bits 0b10
    assert (read.background, read.extent_w_px, read.extent_h_px) == ("rim", 0, 0)
