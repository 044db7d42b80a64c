"""Whether the console, as laid out now, can be read: measured from the widgets' geometry.

:func:`layout_report` says, for the window as it is on the screen: which texts are cut (a label
or switch narrower than its words, or clipped by what holds it), whether any plot's legend lies
over its data area, whether any of the console's parts lie over one another, how much of the
window the SNR-versus-range plot takes, whether every stop row is in view, and whether the plots'
axis titles fit their axes, and the smallest text of each kind in pixels. The status file
(``--status-file``) carries it, so a test driving the real window reads it back; the offscreen
tests call it directly. Nothing here changes the layout.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pyqtgraph as pg
from PySide6.QtCore import QPoint, QRect, Qt
from PySide6.QtGui import QFontInfo
from PySide6.QtWidgets import (
    QAbstractButton,
    QAbstractItemView,
    QAbstractScrollArea,
    QLabel,
    QTabBar,
    QWidget,
)

if TYPE_CHECKING:
    from snrmon.gui.main_window import ConsoleWindow


def global_rect(widget: QWidget) -> QRect:
    """``widget``'s rectangle in screen coordinates."""
    return QRect(widget.mapToGlobal(QPoint(0, 0)), widget.size())


def data_rect(plot: pg.PlotWidget) -> QRect:
    """A pyqtgraph plot's data area (its view box) in screen coordinates."""
    view = plot.getPlotItem().getViewBox()
    scene = view.mapRectToScene(view.boundingRect())
    local = plot.mapFromScene(scene).boundingRect()
    return QRect(plot.viewport().mapToGlobal(local.topLeft()), local.size())


def _rect(r: QRect) -> list[int]:
    return [r.x(), r.y(), r.width(), r.height()]


def _scrolled(widget: QWidget) -> bool:
    """Inside a scroll area (its clipping is scrolling, not cutting)."""
    parent = widget.parentWidget()
    while parent is not None:
        if isinstance(parent, QAbstractScrollArea):
            return True
        parent = parent.parentWidget()
    return False


def text_cut(widget: QWidget) -> bool:
    """A label or switch whose words do not fit it, or that is clipped by what holds it."""
    if isinstance(widget, QLabel):
        text = widget.text()
        if not text or widget.textFormat() == Qt.TextFormat.RichText:
            return False
        rect = widget.contentsRect()
        metrics = widget.fontMetrics()
        if widget.wordWrap():
            needed_h = widget.heightForWidth(widget.width())
            if needed_h > widget.height() + 1:
                return True
        else:
            lines = text.split("\n")
            wide = max(metrics.horizontalAdvance(line) for line in lines)
            high = metrics.height() * len(lines)
            if wide > rect.width() + 1 or high > rect.height() + 1:
                return True
    elif isinstance(widget, QAbstractButton):
        if not widget.text():
            return False
        hint = widget.sizeHint()
        if hint.width() > widget.width() + 1:
            return True
    else:
        return False
    visible = widget.visibleRegion().boundingRect()
    return visible.size() != widget.size() and not _scrolled(widget)


def cut_texts(window: QWidget) -> list[str]:
    """The words of every visible label, button and tab that is cut (see :func:`text_cut`)."""
    out = []
    for widget in window.findChildren(QWidget):
        if not widget.isVisible() or widget.visibleRegion().isEmpty():
            continue  # not on the screen at all (e.g. a dock behind another's tab)
        if isinstance(widget, QLabel | QAbstractButton) and text_cut(widget):
            out.append(widget.text())
        elif isinstance(widget, QTabBar):
            for i in range(widget.count()):
                if widget.tabRect(i).width() < widget.tabSizeHint(i).width():
                    out.append(widget.tabText(i))
    return out


def text_sizes_px(win: ConsoleWindow) -> dict[str, int]:
    """The smallest text on the screen in each kind of the console's parts, in pixels (the
    font's pixel height as this screen renders it): labels and switches, tabs, the stop table
    and its headers, the plots' tick labels, and the box insets' values where they are drawn."""
    sizes: dict[str, int] = {}

    def seen(kind: str, font) -> None:
        px = QFontInfo(font).pixelSize()
        sizes[kind] = min(sizes.get(kind, px), px)

    for widget in win.findChildren(QWidget):
        if not widget.isVisible() or widget.visibleRegion().isEmpty():
            continue
        if isinstance(widget, QLabel) and widget.text():
            seen("labels", widget.font())
        elif isinstance(widget, QAbstractButton) and widget.text():
            seen("switches", widget.font())
        elif isinstance(widget, QTabBar):
            seen("tabs", widget.font())
        elif isinstance(widget, QAbstractItemView):
            seen("tables", widget.font())
    for plot in [p.plot for p in win.range_plots.values()] + [
        p.chart.plot for p in win.panels.values()
    ]:
        if plot.isVisible():
            for name in ("left", "bottom"):
                axis = plot.getPlotItem().getAxis(name)
                seen("plot ticks", axis.style.get("tickFont") or axis.font())
                seen("plot titles", axis.label.font())
    for panel in win.panels.values():
        px = panel.inset.grid.digits_px
        if panel.inset.isVisible() and px is not None:
            sizes["inset values"] = min(sizes.get("inset values", px), px)
    return sizes


def _axis_titles_fit(plot: pg.PlotWidget) -> bool:
    item = plot.getPlotItem()
    for name in ("left", "bottom"):
        axis = item.getAxis(name)
        if not axis.isVisible() or not axis.label.isVisible():
            continue
        text_w = axis.label.boundingRect().width()  # along the axis (the left one is rotated)
        along = axis.geometry().height() if name == "left" else axis.geometry().width()
        if text_w > along:
            return False
    return True


def plot_report(plot: pg.PlotWidget, legend: QWidget | None, holder: QWidget) -> dict[str, Any]:
    data = data_rect(plot)
    out: dict[str, Any] = {
        "rect": _rect(global_rect(holder)),
        "data": _rect(data),
        "axis_titles_fit": _axis_titles_fit(plot),
        "legend": None,
        "legend_over_data": False,
    }
    if legend is not None and legend.isVisible():
        box = global_rect(legend)
        out["legend"] = _rect(box)
        out["legend_over_data"] = box.intersects(data)
    return out


def overlaps(win: ConsoleWindow) -> list[str]:
    """Pairs of the console's parts that lie over one another on the screen (a layout given
    less room than its parts' minimums stacks them): each camera's header, image, inset, strip
    chart and its legend, the range plot, the stop table."""
    parts: list[tuple[str, QWidget]] = []
    for name, panel in win.panels.items():
        parts += [
            (f"{name} header", panel.header),
            (f"{name} image", panel.view),
            (f"{name} inset", panel.inset),
            (f"{name} strip chart legend", panel.chart.legend),
            (f"{name} strip chart", panel.chart.plot),
        ]
    for name, plot in win.range_plots.items():
        parts += [(f"{name} range plot", plot.plot), (f"{name} range legend", plot.legend)]
    parts.append(("stop table", win.stop_table))
    shown = [(n, global_rect(w)) for n, w in parts if w.isVisible()]
    out = []
    for i, (a, ra) in enumerate(shown):
        for b, rb in shown[i + 1 :]:
            if ra.intersects(rb):
                out.append(f"{a} / {b}")
    return out


def layout_report(win: ConsoleWindow) -> dict[str, Any]:
    """What a reader of the window sees (module docstring)."""
    area = max(win.width() * win.height(), 1)
    ranges = {}
    for name, plot in win.range_plots.items():
        if not plot.isVisible():
            continue
        r = plot_report(plot.plot, plot.legend, plot)
        r["area_fraction"] = plot.width() * plot.height() / area
        d = data_rect(plot.plot)
        r["data_fraction"] = d.width() * d.height() / area
        ranges[name] = r
    charts = {
        name: plot_report(panel.chart.plot, panel.chart.legend, panel.chart)
        for name, panel in win.panels.items()
        if panel.chart.isVisible()
    }
    table = win.stop_table
    return {
        "window": [win.width(), win.height()],
        "range_plots": ranges,
        "strip_charts": charts,
        "stops": {
            "rows": table.proxy.rowCount(),
            "in_view": table.rows_in_view() if table.isVisible() else 0,
            "visible": table.isVisible(),
            "columns_fit": not table.horizontalScrollBar().isVisible(),
            "hidden_columns": list(table.hidden_columns),
        },
        "cut_texts": cut_texts(win),
        "overlaps": overlaps(win),
        "images_shown": all(p.view.isVisible() for p in win.panels.values()),
        "text_px": text_sizes_px(win),
    }
