"""The live SNR-versus-range table: one row per stop and camera (``Session.stops()``)."""

from __future__ import annotations

import math

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QAbstractItemView, QHeaderView, QTableWidget, QTableWidgetItem

from snrmon.acquisition.stops.table import StopRow

COLUMNS = (
    ("stop", "Stop number (M = marked by the operator)"),
    ("camera", "Camera"),
    ("LRF range (m)", "Rangefinder range at the stop (m)"),
    ("GPS range (m)", "GPS slant range at the stop (m)"),
    ("frames", "Valid frames summarised (the paper uses the first 100 consecutive)"),
    ("SNR mean", "Mean peak SNR over the stop's frames (Eq. 4)"),
    ("SNR std", "Sample std of the peak SNR over the stop's frames"),
    (
        "background",
        "The background the stop's frames were measured against: rim (Eq. 4's 7x7 rim), "
        "extent_rim (outside the segmented drone and a guard band: a drone wider than the box) "
        "or rect (the operator's clear-sky rectangle); most used first",
    ),
    ("model", "The model's SNR at the stop's range, per curve"),
    (
        "state",
        "complete (100 frames) / collecting / ended short; 'resolved' where the model calls the "
        "small dimension resolved (wider than a pixel)",
    ),
)


def _num(v: float | None, fmt: str) -> str:
    return "--" if v is None or not math.isfinite(v) else format(v, fmt)


def row_texts(r: StopRow) -> list[str]:
    """The table cells of one stop row, formatted."""
    model = ", ".join(f"{k} {v:.1f}" for k, v in r.model_snr.items()) or "--"
    if r.complete:
        state = "complete"
    elif r.t_end_ns is not None:
        state = "ended short"
    else:
        state = "collecting"
    if r.resolved:
        state += ", resolved"
    return [
        f"{r.stop}{' M' if r.manual else ''}",
        r.camera,
        _num(r.lrf_range_m, ".1f"),
        _num(r.gps_range_m, ".1f"),
        str(r.n_frames),
        _num(r.snr_mean, ".2f"),
        _num(r.snr_std, ".2f"),
        r.background or "--",
        model,
        state,
    ]


class StopTableView(QTableWidget):
    """Read-only table refreshed from a list of :class:`StopRow`."""

    def __init__(self, parent=None) -> None:
        super().__init__(0, len(COLUMNS), parent)
        self.setHorizontalHeaderLabels([c for c, _ in COLUMNS])
        for i, (_, tip) in enumerate(COLUMNS):
            self.horizontalHeaderItem(i).setToolTip(tip)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setAlternatingRowColors(True)
        self.verticalHeader().setVisible(False)
        self.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.horizontalHeader().setStretchLastSection(True)
        self.setToolTip("Stops found by the rangefinder/GPS or marked by the operator (M key).")
        self._shown: list[list[str]] = []

    def show_rows(self, rows: list[StopRow]) -> None:
        texts = [row_texts(r) for r in rows]
        if texts == self._shown:
            return
        at_bottom = self.verticalScrollBar().value() == self.verticalScrollBar().maximum()
        self.setRowCount(len(texts))
        for i, cells in enumerate(texts):
            for j, text in enumerate(cells):
                item = self.item(i, j)
                if item is None:
                    item = QTableWidgetItem(text)
                    align = Qt.AlignmentFlag.AlignRight if j >= 2 else Qt.AlignmentFlag.AlignLeft
                    item.setTextAlignment(align | Qt.AlignmentFlag.AlignVCenter)
                    self.setItem(i, j, item)
                elif item.text() != text:
                    item.setText(text)
        self._shown = texts
        if at_bottom:
            self.scrollToBottom()
