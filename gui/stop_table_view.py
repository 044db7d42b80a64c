"""The live SNR-versus-range table: one row per stop and camera (``Session.stops()``).

Each of the model's SNR values at the stop's range is a column of its own (the paper's four
curves, then the expected Eq. (4) readings of whatever background rules the rows carry; SNR is
dimensionless, the headers' tooltips name each in full), then the model's band and measured /
expected, each row's against the expected reading of the rule that row was measured with (its
background: ``rim`` the paper's 7x7 rim, ``extent_rim`` the rim outside the drone's extent),
the rule named after the ratio, coloured like the camera header (green inside the band, amber
near, red outside: :attr:`snrmon.acquisition.stops.table.StopRow.agreement`, computed where the
row is built), then the PSF the model values were computed with ("preset PSF", "fitted PSF":
:attr:`~snrmon.acquisition.stops.table.StopRow.model_psf_label`; the ratio's tooltip gives it
in full). Ranges in metres, the model's sky in kelvin. Each column's key is the stop table's name
for it, the one ``Session.stops()``, the CSV and the campaign's Parquet use
(:mod:`snrmon.acquisition.stops.columns`); a per-frame value declared for the stop table adds a
column of its mean after the SNR std (:func:`frame_mean_columns`). Click a column's header to
sort by it; Ctrl+C (or the context menu, or Ctrl+Shift+C anywhere in the console) copies the
selected rows, or all of them, as the report's CSV (:mod:`snrmon.acquisition.report.stop_csv`).
Where the table is narrower than its columns, the model's sky, the background, the SNR's std,
the GPS range and the model's PSF give way, in that order (:data:`YIELDING`), and come back when
it is wide enough.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from PySide6.QtCore import QAbstractTableModel, QModelIndex, QSortFilterProxyModel, Qt
from PySide6.QtGui import QBrush, QColor, QKeySequence
from PySide6.QtWidgets import QAbstractItemView, QApplication, QHeaderView, QMenu, QTableView

from snrmon.acquisition.prediction import CURVES, EXPECTED_EXTENT, EXPECTED_RIM
from snrmon.acquisition.report.stop_csv import csv_rows, csv_text
from snrmon.acquisition.stops.columns import frame_mean_columns as stop_frame_means
from snrmon.acquisition.stops.table import StopRow
from snrmon.gui import theme as th
from snrmon.gui.model_curves import curve_label, is_expected

MISSING = -math.inf  # a missing number sorts first
SHORT = {  # the model's curves in a narrow column's header (the tooltip says it in full)
    "small": "model\nsmall unc.",
    "large": "model\nlarge unc.",
    "small_corrected": "model\nsmall corr.",
    "large_corrected": "model\nlarge corr.",
}


@dataclass(frozen=True)
class Column:
    key: str
    title: str
    tip: str
    text: Callable[[StopRow], str]
    sort: Callable[[StopRow], object]
    align_right: bool = True


# Where the table is narrower than its columns, these give way first (in this order), so the
# measurement, the expected readings and each row's measured / expected stay in view (on a
# 1366 x 768 screen the ratio was past the table's right edge with the paper's four curves
# shown); they come back when the table is wide enough.
YIELDING = (
    "model_sky_temp_k",
    "background",
    "snr_std",
    "gps_range_m",
    "psf",
    "model_small",
    "model_large",
    "model_small_corrected",
    "model_large_corrected",
)
CELL_PAD_PX = 14
SORT_ARROW_PX = 24  # the sorted column's header draws an arrow beside its words


def _num(v: float | None, fmt: str) -> str:
    return "--" if v is None or not math.isfinite(v) else format(v, fmt)


def _key(v: float | None) -> float:
    return MISSING if v is None or not math.isfinite(v) else float(v)


def state_text(r: StopRow) -> str:
    if r.reading.complete:
        state = "complete"
    elif r.place.t_end_ns is not None:
        state = "ended short"
    else:
        state = "collecting"
    return state + (", resolved" if r.model.resolved else "")


def model_keys(rows: list[StopRow]) -> list[str]:
    """The model's curves the rows carry, the paper's four first, then the expected readings
    (any rule), then any other; not the bands' edges."""
    seen: list[str] = []
    for r in rows:
        for k in r.model.model_snr:
            if k not in seen and not k.endswith(("_lower", "_upper")):
                seen.append(k)
    return sorted(
        seen,
        key=lambda k: (CURVES.index(k) if k in CURVES else len(CURVES) + (not is_expected(k)), k),
    )


def columns(rows: list[StopRow]) -> list[Column]:
    """The table's columns for ``rows``. The band and the ratio are each row's own: against the
    expected reading of the rule that row was measured with (:attr:`StopRow.agreement`), the
    rule named in the ratio's cell."""
    keys = model_keys(rows)
    cols = measurement_columns() + [model_column(k) for k in keys]
    if any(is_expected(k) for k in keys):
        cols += agreement_columns()
    if any(r.model.psf_source for r in rows):
        cols.append(PSF_COLUMN)
    return cols + closing_columns()


def measurement_columns() -> list[Column]:
    """The stop, its camera and ranges, and what was measured at it (first in the table)."""
    return [
        Column(
            "stop",
            "stop",
            "Stop number (M = marked by the operator)",
            lambda r: f"{r.stop}{' M' if r.manual else ''}",
            lambda r: r.stop,
            False,
        ),
        Column("camera", "cam.", "Camera", lambda r: r.camera, lambda r: r.camera, False),
        Column(
            "lrf_range_m",
            "LRF\n(m)",
            "Rangefinder range at the stop (m)",
            lambda r: _num(r.place.lrf_range_m, ".1f"),
            lambda r: _key(r.place.lrf_range_m),
        ),
        Column(
            "gps_range_m",
            "GPS\n(m)",
            "GPS slant range at the stop (m)",
            lambda r: _num(r.place.gps_range_m, ".1f"),
            lambda r: _key(r.place.gps_range_m),
        ),
        Column(
            "n_frames",
            "frames",
            "Valid consecutive frames summarised (the paper uses the first 100)",
            lambda r: str(r.reading.n_frames),
            lambda r: r.reading.n_frames,
        ),
        Column(
            "snr_mean",
            "SNR\n± error",
            "Mean peak SNR over the stop's frames (Eq. 4) +/- its error of the mean (the frames' "
            "autocorrelation counted): the stop's error bar",
            lambda r: f"{_num(r.reading.snr_mean, '.2f')} ± {_num(r.reading.snr_sem, '.2f')}",
            lambda r: _key(r.reading.snr_mean),
        ),
        Column(
            "snr_std",
            "SNR\nstd",
            "Sample std of the peak SNR over the stop's frames",
            lambda r: _num(r.reading.snr_std, ".2f"),
            lambda r: _key(r.reading.snr_std),
        ),
        *frame_mean_columns(),
        Column(
            "background",
            "background",
            "The background the stop's frames were measured against: rim (Eq. 4's 7x7 rim), "
            "extent_rim (outside the segmented drone and a guard band: a drone wider than the "
            "box) or rect (the operator's clear-sky rectangle); most used first",
            lambda r: r.reading.background or "--",
            lambda r: r.reading.background,
            False,
        ),
    ]


def model_column(key: str) -> Column:
    """The model's SNR ``key`` (a curve or an expected reading) at each row's range."""
    return Column(
        f"model_{key}",
        SHORT.get(key) or _model_title(key),
        f"The model's SNR at the stop's range: {curve_label(key)} (dimensionless)",
        lambda r: _num(r.model.model_snr.get(key), ".1f"),
        lambda r: _key(r.model.model_snr.get(key)),
    )


def agreement_columns() -> list[Column]:
    """Each row's band and measured / expected, by the rule of the row's own background."""
    return [
        Column(
            "band",
            "expected\nband",
            "The model's uncertainty band of the expected Eq. (4) reading at the stop's "
            "range, by the background rule the row was measured with (its background)",
            _band_text,
            lambda r: _key(r.agreement.lower) if r.agreement else MISSING,
        ),
        Column(
            "ratio",
            "measured /\nexpected",
            "SNR mean / the expected Eq. (4) reading of the rule the row was measured with "
            "(rim: the paper's 7x7 rim; extent: the rim outside the drone's extent): green "
            "inside the model's band, amber within two errors of the mean of it, red "
            "outside; the cell's tooltip names the PSF the model used",
            _ratio_text,
            lambda r: _key(r.agreement.ratio) if r.agreement else MISSING,
        ),
    ]


PSF_COLUMN = Column(
    "psf",
    "model\nPSF",
    "The PSF the row's corrected and expected values were computed with: preset "
    "(the sensor's, e.g. solved for the paper's average PVF 0.082) or fitted (from "
    "this flight's unresolved stops); the ratio's tooltip gives it in full",
    lambda r: r.model_psf_label or "--",
    lambda r: r.model_psf_label or "",
    False,
)
"""The PSF each row's model values were computed with (shown when any row names one)."""


def closing_columns() -> list[Column]:
    """The model's sky and the row's state (last in the table)."""
    return [
        Column(
            "model_sky_temp_k",
            "sky\n(K)",
            "The background (sky) temperature the model values were computed at (K)",
            lambda r: _num(r.model.model_sky_temp_k, ".1f"),
            lambda r: _key(r.model.model_sky_temp_k),
        ),
        Column(
            "state",
            "state",
            "complete (100 frames) / collecting / ended short; 'resolved' where the model calls "
            "the small dimension resolved (wider than a pixel)",
            state_text,
            state_text,
            False,
        ),
    ]


def frame_mean_columns() -> list[Column]:
    """A column for each per-frame value the stop table carries the mean of (declared on the
    Eq. (4) result: :func:`snrmon.acquisition.stops.columns.frame_mean_columns`), titled by its
    name and unit."""
    out = []
    for c in stop_frame_means():
        unit = f"\n({c.units})" if c.units and c.units != "1" else ""
        out.append(
            Column(
                c.name,
                c.name.replace("_", " ") + unit,
                c.meaning,
                lambda r, k=c.name: _num(r.reading.frame_means.get(k), ".2f"),
                lambda r, k=c.name: _key(r.reading.frame_means.get(k)),
            )
        )
    return out


SHORT_TITLES = {
    EXPECTED_RIM: "expected\n7x7 rim",
    EXPECTED_EXTENT: "expected\nextent rim",
}
"""The expected readings' two-line headers (their tooltips give the rule in words)."""


def _model_title(name: str) -> str:
    """A model curve the console does not abbreviate (an expected reading under some rule) as
    a narrow header: "model SNR", "expected", the rule."""
    if name in SHORT_TITLES:
        return SHORT_TITLES[name]
    label = curve_label(name)
    for prefix in ("expected Eq. (4), ", "expected Eq. (4) "):
        if label.startswith(prefix):
            return f"model\nexpected\n{label[len(prefix) :]}"
    return f"model\n{label}"


RULE_TAGS = {EXPECTED_RIM: "rim", EXPECTED_EXTENT: "extent"}
"""The rule a row's ratio is against, as the word after the ratio in its cell."""


def _ratio_text(r: StopRow) -> str:
    a = r.agreement
    if a is None or not math.isfinite(a.ratio):
        return "--"
    return f"{a.ratio:.2f} {RULE_TAGS.get(a.rule, a.rule)}"


def _band_text(r: StopRow) -> str:
    a = r.agreement
    if a is None or a.lower == a.upper:  # no band stated (the reading itself)
        return "--"
    return f"{a.lower:.1f}–{a.upper:.1f}"


def _ratio_tip(r: StopRow) -> str:
    a = r.agreement
    if a is None:
        return (
            "No expected reading for this row's background (no model, or the clear-sky rectangle)"
        )
    psf = f"; the model's PSF: {r.model.psf_source}" if r.model.psf_source else ""
    return (
        f"SNR mean {a.measured:.2f} / {curve_label(a.rule)} {a.expected:.2f} (the rule of this "
        f"row's background, {r.reading.background}): {a.verdict or 'not decided'}{psf}"
    )


def row_texts(r: StopRow) -> list[str]:
    """The table cells of one stop row, formatted (the columns of this row alone)."""
    return [c.text(r) for c in columns([r])]


class StopTableModel(QAbstractTableModel):
    """The rows and their cells; the view sorts through a proxy by each cell's number."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[StopRow] = []
        self.cols: list[Column] = columns([])
        self.texts: list[list[str]] = []

    def set_rows(self, rows: list[StopRow]) -> bool:
        """Show ``rows``; False when nothing changed."""
        cols = columns(rows)
        texts = [[c.text(r) for c in cols] for r in rows]
        same_cols = [c.title for c in cols] == [c.title for c in self.cols]
        if same_cols and texts == self.texts:
            return False
        if same_cols and len(rows) == len(self.rows):
            self.rows, self.texts = rows, texts
            last = self.index(len(rows) - 1, len(cols) - 1)
            self.dataChanged.emit(self.index(0, 0), last)
            return True
        self.beginResetModel()
        self.rows, self.cols, self.texts = rows, cols, texts
        self.endResetModel()
        return True

    def rowCount(self, parent=QModelIndex()) -> int:  # noqa: B008, N802 (Qt's name)
        return 0 if parent.isValid() else len(self.rows)

    def columnCount(self, parent=QModelIndex()) -> int:  # noqa: B008, N802 (Qt's name)
        return 0 if parent.isValid() else len(self.cols)

    def headerData(self, section, orientation, role=Qt.ItemDataRole.DisplayRole):  # noqa: N802
        if orientation != Qt.Orientation.Horizontal or not 0 <= section < len(self.cols):
            return None
        if role == Qt.ItemDataRole.DisplayRole:
            return self.cols[section].title
        if role == Qt.ItemDataRole.ToolTipRole:
            return self.cols[section].tip
        return None

    def data(self, index, role=Qt.ItemDataRole.DisplayRole):
        if not index.isValid():
            return None
        row, col = self.rows[index.row()], self.cols[index.column()]
        if role == Qt.ItemDataRole.DisplayRole:
            return self.texts[index.row()][index.column()]
        if role == Qt.ItemDataRole.UserRole:
            return col.sort(row)
        if role == Qt.ItemDataRole.TextAlignmentRole:
            side = Qt.AlignmentFlag.AlignRight if col.align_right else Qt.AlignmentFlag.AlignLeft
            return int(side | Qt.AlignmentFlag.AlignVCenter)
        if col.key == "ratio" and role == Qt.ItemDataRole.ToolTipRole:
            return _ratio_tip(row)
        if col.key == "ratio" and role in (
            Qt.ItemDataRole.BackgroundRole,
            Qt.ItemDataRole.ForegroundRole,
        ):
            a = row.agreement
            colours = th.current().verdicts.get(a.verdict if a else "")
            if colours is None:
                return None
            fill, ink = colours
            return QBrush(QColor(fill if role == Qt.ItemDataRole.BackgroundRole else ink))
        return None


class StopTableView(QTableView):
    """Read-only, sortable table refreshed from a list of :class:`StopRow`."""

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.table = StopTableModel()
        self.proxy = QSortFilterProxyModel(self)
        self.proxy.setSourceModel(self.table)
        self.proxy.setSortRole(Qt.ItemDataRole.UserRole)
        self.setModel(self.proxy)
        self.setSortingEnabled(True)
        self.sortByColumn(0, Qt.SortOrder.AscendingOrder)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setAlternatingRowColors(True)
        self.setWordWrap(False)
        self.verticalHeader().setVisible(False)
        header = self.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeMode.Fixed)
        header.setStretchLastSection(True)
        header.setDefaultAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter)
        header.sortIndicatorChanged.connect(lambda *_: self.fit_columns())
        self.hidden_columns: list[str] = []
        self.setContextMenuPolicy(Qt.ContextMenuPolicy.CustomContextMenu)
        self.customContextMenuRequested.connect(self._menu)
        self.setToolTip(
            "Stops found by the rangefinder/GPS or marked by the operator (M key). Click a "
            "header to sort; Ctrl+C copies the selected rows (or all) as CSV."
        )
        self.apply_theme()

    def apply_theme(self) -> None:
        """Rows as high as the current font needs, no more (every stop in view)."""
        rows = self.verticalHeader()
        rows.setMinimumSectionSize(1)
        rows.setDefaultSectionSize(self.fontMetrics().height() + 3)
        self.fit_columns()
        self.viewport().update()

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        super().resizeEvent(event)
        self.fit_columns()

    def column_widths(self) -> list[int]:
        """Each column as wide as its widest line (header or cell) in the current font; the
        sorted one with room for the sort arrow."""
        metrics = self.fontMetrics()
        head = self.horizontalHeader().fontMetrics()
        sorted_col = self.horizontalHeader().sortIndicatorSection()
        widths = []
        for j, col in enumerate(self.table.cols):
            lines = [head.horizontalAdvance(line) for line in col.title.split("\n")]
            cells = [metrics.horizontalAdvance(t[j]) for t in self.table.texts]
            w = max(lines + cells) + CELL_PAD_PX
            widths.append(w + (SORT_ARROW_PX if j == sorted_col else 0))
        return widths

    def fit_columns(self) -> None:
        """Widths by content; where they do not fit, the :data:`YIELDING` columns hide."""
        widths = self.column_widths()
        keys = [c.key for c in self.table.cols]
        room = self.viewport().width()
        hidden: list[str] = []
        total = sum(widths)
        for key in YIELDING:
            if total <= room:
                break
            if key in keys:
                hidden.append(key)
                total -= widths[keys.index(key)]
        header = self.horizontalHeader()
        for j, (key, w) in enumerate(zip(keys, widths, strict=True)):
            self.setColumnHidden(j, key in hidden)
            if header.sectionSize(j) != w and j < len(keys) - 1:
                header.resizeSection(j, w)
        self.hidden_columns = hidden

    @property
    def rows(self) -> list[StopRow]:
        return self.table.rows

    def show_rows(self, rows: list[StopRow]) -> None:
        """Show ``rows`` (each row's band and ratio by its own rule)."""
        bar = self.verticalScrollBar()
        at_bottom = bar.value() == bar.maximum()
        if self.table.set_rows(list(rows)):
            self.fit_columns()
            if at_bottom:
                self.scrollToBottom()

    def shown_rows(self) -> list[StopRow]:
        """The rows in the order shown (sorted as the operator chose)."""
        return [
            self.table.rows[self.proxy.mapToSource(self.proxy.index(i, 0)).row()]
            for i in range(self.proxy.rowCount())
        ]

    def cells(self) -> list[list[str]]:
        """Every cell's text as shown, row by row (tests, the status file)."""
        return [
            [str(self.proxy.index(i, j).data()) for j in range(self.proxy.columnCount())]
            for i in range(self.proxy.rowCount())
        ]

    def csv(self) -> str:
        """The selected rows (all when none is selected), in the order shown, as the report's
        CSV (:func:`snrmon.acquisition.report.stop_csv.csv_text`)."""
        picked = sorted({i.row() for i in self.selectionModel().selectedRows()})
        shown = self.shown_rows()
        rows = [shown[i] for i in picked] if picked else shown
        return csv_text(csv_rows(rows))

    def copy_csv(self) -> int:
        """Copy :meth:`csv` to the clipboard; returns the number of rows copied."""
        text = self.csv()
        QApplication.clipboard().setText(text)
        return max(text.count("\n") - 1, 0)

    def keyPressEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        if event.matches(QKeySequence.StandardKey.Copy):
            self.copy_csv()
            event.accept()
            return
        super().keyPressEvent(event)

    def _menu(self, pos) -> None:
        menu = QMenu(self)
        menu.addAction("Copy as CSV (selected rows, or all)", self.copy_csv)
        menu.exec(self.viewport().mapToGlobal(pos))

    def rows_in_view(self) -> int:
        """How many rows are wholly inside the viewport now."""
        area = self.viewport().rect()
        return sum(
            1
            for i in range(self.proxy.rowCount())
            if area.contains(self.visualRect(self.proxy.index(i, 0)))
        )
