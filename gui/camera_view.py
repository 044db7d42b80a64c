"""One camera's live image: levels (histogram control and robust auto-levels), zoom and pan, the
operator's click that sets the ROI, and the measurement's geometry drawn on the image.

The view never receives frames: the main window's timer hands it the newest frame the display's
worker made ready (:class:`snrmon.gui.frame_feed.ShownFrame`: the frame, its auto-levels and its
image for the screen), and the view skips a frame it has already shown. The view tells the worker
how it draws (:meth:`CameraView.display_request`).
Drawn on the image (paper Fig. 4): the search window centred on the ROI, the box centred on the
measured peak, and the inner edge of its one-pixel rim (the rim pixels lie between the two); and
a cyan ring around where the drone's GPS position projects into the camera (hidden with no
projection), and, where the image is drawn so small that the box would be under 8 screen
pixels, a square of that size at the peak. The palette is grey, white-hot, black-hot or ironbow.
"""

from __future__ import annotations

import math
import time

import cv2
import numpy as np
import pyqtgraph as pg
from pyqtgraph import functions_qimage
from PySide6.QtCore import QPoint, QPointF, QRectF, Qt, Signal
from PySide6.QtGui import QColor, QImage, QPainter, QPainterPath, QPen, QPixmap
from PySide6.QtWidgets import (
    QGraphicsItem,
    QGraphicsPathItem,
    QGraphicsRectItem,
    QLabel,
    QVBoxLayout,
    QWidget,
)

from snrmon.acquisition.engine.status import CameraStatus
from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
from snrmon.gui.display_image import colour_table, shown_rgb32
from snrmon.gui.frame_feed import DisplayRequest, ShownFrame
from snrmon.gui.levels import histogram_range

GPS_COLOR = "#00e5ff"  # cyan: distinct from the ROI blue, box yellow and peak red
GPS_RING_PX = 30  # the GPS cue: a ring this wide on the screen, the drone visible inside it
MIN_BOX_SCREEN_PX = 8  # the measured box is never drawn smaller on the screen than this
# The palettes an infrared engineer expects (gradient stops 0..1 over the levels, RGB).
PALETTES: dict[str, list[tuple[float, tuple[int, int, int, int]]]] = {
    "grey": [(0.0, (0, 0, 0, 255)), (1.0, (255, 255, 255, 255))],
    "white-hot": [(0.0, (0, 0, 0, 255)), (1.0, (255, 255, 255, 255))],
    "black-hot": [(0.0, (255, 255, 255, 255)), (1.0, (0, 0, 0, 255))],
    "ironbow": [
        (0.0, (0, 0, 0, 255)),
        (0.2, (32, 0, 140, 255)),
        (0.45, (204, 0, 119, 255)),
        (0.7, (255, 120, 0, 255)),
        (0.9, (255, 215, 0, 255)),
        (1.0, (255, 255, 230, 255)),
    ],
}


def _rect_item(colour: str, width: float = 1.5, style=Qt.PenStyle.SolidLine) -> QGraphicsRectItem:
    item = QGraphicsRectItem()
    pen = pg.mkPen(colour, width=width, style=style)
    pen.setCosmetic(True)  # constant on-screen width at any zoom
    item.setPen(pen)
    item.setZValue(10)
    item.setVisible(False)
    return item


def pixel_at(x_view: float, y_view: float) -> tuple[int, int]:
    """The (column, row) of the pixel under an image coordinate; pixel (c, r) spans
    ``[c, c+1) x [r, r+1)`` in a row-major pyqtgraph ImageItem at the origin."""
    return math.floor(x_view), math.floor(y_view)


def square_around(cx: int, cy: int, size_px: int) -> QRectF:
    """The outline of a ``size_px`` square of pixels centred on pixel (cx, cy)."""
    half = size_px // 2
    return QRectF(cx - half, cy - half, size_px, size_px)


def block_mean(pixels: np.ndarray, x_factor: int, y_factor: int) -> np.ndarray:
    """``pixels`` (2-D) averaged over blocks of ``y_factor`` rows by ``x_factor`` columns, in the
    input dtype (rounded); the last partial block of each axis is left out, as pyqtgraph does.

    ``cv2.resize`` with INTER_AREA and integer factors is an exact block mean computed in C with
    the GIL released: ~0.1 ms for a 1280 x 720 uint16 frame where pyqtgraph's float64 numpy mean
    takes ~8 ms of the GUI thread.
    """
    if x_factor == 1 and y_factor == 1:
        return pixels
    h, w = pixels.shape
    rows, cols = h // y_factor, w // x_factor
    if rows == 0 or cols == 0:
        return pixels[:0, :0]
    whole = pixels[: rows * y_factor, : cols * x_factor]
    return cv2.resize(whole, (cols, rows), interpolation=cv2.INTER_AREA)


class ScreenMarker(QGraphicsPathItem):
    """A hollow ring ("o") or square ("s") of a fixed size on the screen, centred on an image
    point: a Qt item drawn and bounded in C++ (pyqtgraph's ScatterPlotItem computed its bounds
    and drew its symbol in Python on every paint of the image, 60 times a second: a third of
    the camera view's paint)."""

    def __init__(self, symbol: str, size_px: float, colour: str) -> None:
        super().__init__()
        self.symbol = symbol
        self.size_px = float(size_px)
        path = QPainterPath()
        box = QRectF(-size_px / 2, -size_px / 2, size_px, size_px)
        if symbol == "o":
            path.addEllipse(box)
        elif symbol == "s":
            path.addRect(box)
        else:
            raise ValueError(f"unknown marker symbol {symbol!r} (o, s)")
        self.setPath(path)
        pen = pg.mkPen(colour, width=2)
        pen.setCosmetic(True)
        self.setPen(pen)
        self.setBrush(QColor(0, 0, 0, 0))  # hollow: what it marks stays in view inside
        self.setFlag(QGraphicsItem.GraphicsItemFlag.ItemIgnoresTransformations)
        self.setZValue(11)
        self.setVisible(False)

    def centre_on(self, x: float, y: float) -> None:
        """Centre the marker on image point (x, y)."""
        self.setPos(float(x), float(y))

    def centre(self) -> tuple[float, float]:
        """The image point the marker is centred on."""
        return self.pos().x(), self.pos().y()


class DisplayImageItem(pg.ImageItem):
    """A row-major ImageItem whose auto-downsampling of integer frames is :func:`block_mean`.

    The image keeps the camera's DN (the histogram and the levels stay in DN); only the copy drawn
    on screen is reduced to the resolution it is shown at. Float, NaN-carrying or colour images,
    and the not-downsampled case, go pyqtgraph's own way.

    An 8- or 16-bit frame is drawn as a 32-bit RGB image made in one compiled pass
    (:mod:`snrmon.gui.display_image`; its colour table rebuilt when the levels or the colours
    change): every frame at 60 frames/s is drawn.

    :attr:`frames_painted` counts the distinct frames (by :attr:`frame_seq`, set by the view
    before ``setImage``) that were painted: what reached the screen, not what was handed over.
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.frame_seq: int | None = None
        self.frames_painted = 0
        self._painted_seq: int | None = None
        self._table_for: tuple | None = None  # (levels, lut bytes, n values) of _table
        self._table: np.ndarray | None = None
        self._argb: list[np.ndarray] = []  # the pixels of self.qimage (it does not own them)
        # The image made off the GUI thread for the next frame (frame_feed.ShownFrame): drawn
        # as it is when it was made with what this item draws with.
        self.prepared: tuple[tuple, np.ndarray] | None = None
        self.render_key: tuple | None = None  # (x, y factors, levels, lut bytes, n values)
        self.render_lut: np.ndarray | None = None  # the colours of the last render
        self.images_made_here = 0  # renders that could not use a prepared image
        self._factors: tuple[int, int] | None = None  # the reduction at the current transform

    def viewTransformChanged(self) -> None:  # noqa: N802 (pyqtgraph's name)
        # The only time the reduction can change: found here once, not on every frame (its
        # mapping through the device transform is pyqtgraph's Python, ~0.2 ms a render).
        self._factors = None
        super().viewTransformChanged()

    def _computeDownsampleFactors(self) -> tuple[int, int]:  # noqa: N802 (pyqtgraph's name)
        if self._factors is None:
            self._factors = super()._computeDownsampleFactors()
        return self._factors

    def paint(self, painter, *args) -> None:
        super().paint(painter, *args)
        if self.frame_seq != self._painted_seq and self.qimage is not None:
            self._painted_seq = self.frame_seq
            self.frames_painted += 1

    def render(self) -> None:
        image = self.image
        if (
            image is None
            or not self.autoDownsample
            or image.ndim != 2
            or image.dtype.kind not in "ui"
            or self.axisOrder != "row-major"
        ):
            return super().render()
        self._unrenderable = True
        if image.size == 0:
            return
        xds, yds = self._computeDownsampleFactors()
        if xds is None:
            return
        if self._render_rgb32(image, xds, yds):
            return
        shown = block_mean(image, xds, yds)
        if shown.size == 0:
            return
        self._lastDownsample = (xds, yds)
        lut = self.lut(shown, 256) if callable(self.lut) else self.lut
        qimage = functions_qimage.try_make_qimage(shown, levels=self.levels, lut=lut)
        if qimage is None:  # a LUT or levels form the fast path does not take
            return super().render()
        self.qimage = qimage
        self._renderRequired = False
        self._unrenderable = False

    def _render_rgb32(self, image: np.ndarray, xds: int, yds: int) -> bool:
        """``image`` (8- or 16-bit unsigned) reduced by ``xds`` x ``yds`` as a 32-bit RGB
        QImage; False for any other form (pyqtgraph's way then)."""
        levels = self.levels
        if image.dtype not in (np.uint8, np.uint16) or levels is None or np.ndim(levels) != 1:
            return False
        rows, cols = image.shape[0] // yds, image.shape[1] // xds
        if rows == 0 or cols == 0:
            return False
        lut = self.lut(image, 256) if callable(self.lut) else self.lut
        if lut is not None and (np.ndim(lut) != 2 or np.shape(lut)[1] not in (3, 4)):
            return False
        n_values = 1 << (8 * image.dtype.itemsize)
        lut_key = None if lut is None else lut.tobytes()
        levels = (float(levels[0]), float(levels[1]))
        self.render_key = (xds, yds, levels, lut_key, n_values)
        self.render_lut = lut
        prepared, self.prepared = self.prepared, None
        if prepared is not None and prepared[0] == self.render_key:
            argb = prepared[1]  # the feed keeps it until two frames later
        else:
            self.images_made_here += 1
            key = (levels, lut_key, n_values)
            if key != self._table_for:
                self._table = colour_table(levels, lut, n_values)
                self._table_for = key
            if len(self._argb) != 2 or self._argb[0].shape != (rows, cols):
                self._argb = [np.empty((rows, cols), np.uint32) for _ in range(2)]
            # Two arrays in turn: the QImage drawn last keeps its pixels until this one
            # replaces it.
            self._argb.reverse()
            argb = self._argb[0]
            shown_rgb32(image, xds, yds, self._table, argb)
        self._lastDownsample = (xds, yds)
        self.qimage = QImage(argb.data, cols, rows, cols * 4, QImage.Format.Format_RGB32)
        self._renderRequired = False
        self._unrenderable = False
        return True


LOUPE_PX = 21  # the loupe shows this many image pixels square around its centre
LOUPE_ZOOM = 6  # each drawn this many screen pixels wide
LOUPE_FOLLOWS_POINTER_S = 2.0  # after the pointer leaves, the loupe goes back to the track
LOUPE_ON_TRACK_MIN_PX = 600  # on a narrower image the loupe shows only under the pointer


def loupe_rgb(pixels: np.ndarray, cx: int, cy: int, levels, lut: np.ndarray | None) -> np.ndarray:
    """The :data:`LOUPE_PX`-square crop of ``pixels`` centred on (cx, cy) in the view's colours
    (0xffRRGGBB, uint32): ``levels`` (lo, hi) onto grey or onto the ``lut``'s colours, as the
    image is drawn; pixels beyond the frame's edge black."""
    half = LOUPE_PX // 2
    out = np.zeros((LOUPE_PX, LOUPE_PX), np.uint32) | np.uint32(0xFF000000)
    h, w = pixels.shape
    y0, y1, x0, x1 = (
        max(cy - half, 0),
        min(cy + half + 1, h),
        max(cx - half, 0),
        min(cx + half + 1, w),
    )
    if y0 >= y1 or x0 >= x1:
        return out
    lo, hi = float(levels[0]), float(levels[1])
    span = hi - lo if hi != lo else 1.0
    crop = (pixels[y0:y1, x0:x1].astype(np.float64) - lo) / span
    if lut is None:
        grey = np.clip(crop * 255.0, 0, 255).astype(np.uint32)
        rgb = grey * 0x010101 | np.uint32(0xFF000000)
    else:
        index = np.clip(crop * len(lut), 0, len(lut) - 1).astype(np.intp)
        c = np.asarray(lut)[index, :3].astype(np.uint32)
        rgb = (c[..., 0] << 16) | (c[..., 1] << 8) | c[..., 2] | np.uint32(0xFF000000)
    out[y0 - (cy - half) : y1 - (cy - half), x0 - (cx - half) : x1 - (cx - half)] = rgb
    return out


class Loupe(QLabel):
    """A magnified inset in the image's corner around the pointer (while it moves over the
    image) or the track: :data:`LOUPE_PX` pixels square at :data:`LOUPE_ZOOM` x, the centre
    pixel outlined, so the drone can be told from its neighbours before the click."""

    def __init__(self, parent: QWidget) -> None:
        super().__init__(parent)
        side = LOUPE_PX * LOUPE_ZOOM
        self.setFixedSize(side + 4, side + 4)
        self.setStyleSheet("QLabel { border: 2px solid #00e5ff; background: black; }")
        self.setToolTip("Loupe: the pixels around the pointer, or the track, magnified")
        self.centre: tuple[int, int] | None = None
        self.setVisible(False)

    def show_around(self, rgb: np.ndarray, centre: tuple[int, int]) -> None:
        side = LOUPE_PX * LOUPE_ZOOM
        image = QImage(rgb.data, LOUPE_PX, LOUPE_PX, 4 * LOUPE_PX, QImage.Format.Format_RGB32)
        big = image.scaled(
            side,
            side,
            Qt.AspectRatioMode.IgnoreAspectRatio,
            Qt.TransformationMode.FastTransformation,
        )
        painter = QPainter(big)
        painter.setPen(QPen(QColor("#ff4040"), 1))
        mid = (LOUPE_PX // 2) * LOUPE_ZOOM
        painter.drawRect(mid, mid, LOUPE_ZOOM - 1, LOUPE_ZOOM - 1)
        painter.end()
        self.setPixmap(QPixmap.fromImage(big))
        self.centre = centre
        self.setVisible(True)


class CameraView(QWidget):
    """Image, histogram/levels control and overlays of one camera.

    Signals:
        roi_clicked(camera, x, y): the operator clicked pixel column ``x``, row ``y``.
    """

    roi_clicked = Signal(str, int, int)
    # the pixel under the pointer and its value (DN of the shown frame): camera, column, row, DN
    pointed = Signal(str, int, int, float)

    def __init__(
        self,
        camera: str,
        shape: tuple[int, int],
        config: PeakSnrConfig,
        parent: QWidget | None = None,
    ) -> None:
        super().__init__(parent)
        self.camera = camera
        self.shape = shape
        self.config = config
        self.auto_levels = True
        self.frames_shown = 0
        self._last_seq: int | None = None
        self._auto_generation = 0  # raised each time auto-levels is asked for again

        self.graphics = pg.GraphicsLayoutWidget()
        self.view = self.graphics.addViewBox(lockAspect=True, invertY=True, enableMenu=False)
        # autoDownsample: a 1280x720 frame is mapped at the resolution it is shown at, not
        # pixel for pixel (the LUT pass is most of the drawing cost).
        self.image = DisplayImageItem(axisOrder="row-major", autoDownsample=True)
        self.view.addItem(self.image)
        self.histogram = pg.HistogramLUTItem(image=self.image)
        # The histogram item recomputes and replots the image histogram on every new frame, in
        # the GUI thread. The display's worker takes it instead, once a second
        # (frame_feed.HISTOGRAM_EVERY_S), and the view only plots it; its DN range moves only
        # when the data leave it (levels.histogram_range), so that its axis is not re-typeset.
        self.image.sigImageChanged.disconnect(self.histogram.imageChanged)
        self.histogram_range: tuple[float, float] | None = None
        self.histogram.sigLevelsChanged.connect(self._levels_dragged)
        # its tick labels only change with the histogram's range: blit them, don't re-typeset
        self.histogram.axis.setCacheMode(QGraphicsItem.CacheMode.DeviceCoordinateCache)
        self.graphics.addItem(self.histogram)
        self.search_rect = _rect_item("#4aa3ff", style=Qt.PenStyle.DashLine)
        self.box_rect = _rect_item("#ffd34d")
        self.rim_inner_rect = _rect_item("#ffd34d", width=1.0, style=Qt.PenStyle.DotLine)
        self.peak_rect = _rect_item("#ff4040", width=1.0)
        for item in (self.search_rect, self.box_rect, self.rim_inner_rect, self.peak_rect):
            self.view.addItem(item, ignoreBounds=True)
        # a ring around where the GPS puts the drone, not a cross over it: the drone itself
        # stays in view inside for the click
        self.gps_marker = ScreenMarker("o", GPS_RING_PX, GPS_COLOR)
        # the box at the peak where the image is drawn so small that its box would be under
        # MIN_BOX_SCREEN_PX on the screen (a 1280-px frame 252 px wide: a 7-px box is 1.4 px)
        self.box_marker = ScreenMarker("s", MIN_BOX_SCREEN_PX + 4, "#ffd34d")
        self.view.addItem(self.box_marker, ignoreBounds=True)
        self.palette = "grey"
        self.gps_marker.setToolTip("GPS: the drone's GPS position projected into this camera")
        self.view.addItem(self.gps_marker, ignoreBounds=True)
        h, w = shape
        self.image.setImage(np.zeros((h, w), np.uint16), autoLevels=False, levels=(0, 1))
        self.view.setRange(QRectF(0, 0, w, h), padding=0.0)
        self.graphics.scene().sigMouseClicked.connect(self._scene_clicked)
        self.graphics.scene().sigMouseMoved.connect(self._scene_moved)
        self.setToolTip(
            f"{camera}: click the drone to set the ROI; wheel = zoom, drag = pan. "
            "Levels in DN (drag the histogram handles, or A for auto-levels)."
        )
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.graphics)
        self.loupe = Loupe(self.graphics.viewport())
        self._pointer_s = -math.inf  # when the pointer last moved over the image (monotonic s)

    # ------------------------------------------------------------------ frames
    def show_frame(self, shown: ShownFrame | None) -> bool:
        """Draw the frame made ready by the display's worker (:mod:`snrmon.gui.frame_feed`)
        if it is new, with its levels while auto-levels is on and its image if it was made the
        way this view draws; returns whether anything was drawn."""
        if shown is None or shown.frame.seq == self._last_seq:
            return False
        frame = shown.frame
        self._last_seq = frame.seq
        levels = self.histogram.getLevels()
        if self.auto_levels and tuple(levels) != shown.levels:
            # the worker moves them only beyond a dead band: a repaint of the histogram
            # control (~2 ms) a few times a minute, not at every frame
            levels = shown.levels
            self._set_levels_quietly(*levels)
        self.image.frame_seq = frame.seq
        self.image.prepared = None if shown.image is None else (shown.image_key, shown.image)
        self.image.setImage(frame.pixels, autoLevels=False, levels=levels)
        if shown.histogram is not None:
            self.show_histogram(*shown.histogram)
        self.frames_shown += 1
        return True

    def show_histogram(self, dn: np.ndarray, counts: np.ndarray) -> None:
        """Plot a frame's histogram (``dn``: the bins' left edges) in the levels control, over
        a range that holds it and the levels (:func:`snrmon.gui.levels.histogram_range`)."""
        if dn.size == 0:
            return
        self.histogram.plot.setData(dn, counts)
        lo, hi = self.histogram.getLevels()
        wanted = histogram_range(
            min(float(dn[0]), lo), max(float(dn[-1]), hi), self.histogram_range
        )
        if wanted != self.histogram_range:
            self.histogram_range = wanted
            self.histogram.setHistogramRange(*wanted, padding=0.0)

    def display_request(self) -> DisplayRequest | None:
        """How this view draws its frames (the reduction and colours of its last image, the
        levels), for the display's worker to make the next ones so; None before the first."""
        key = self.image.render_key
        if key is None:
            return None
        lo, hi = self.histogram.getLevels()
        return DisplayRequest(
            x_factor=key[0],
            y_factor=key[1],
            lut=self.image.render_lut,
            lut_key=key[3],
            auto_levels=self.auto_levels,
            levels=(float(lo), float(hi)),
            auto_generation=self._auto_generation,
        )

    def _set_levels_quietly(self, lo: float, hi: float) -> None:
        self.histogram.sigLevelsChanged.disconnect(self._levels_dragged)
        try:
            self.histogram.setLevels(lo, hi)
        finally:
            self.histogram.sigLevelsChanged.connect(self._levels_dragged)

    def _levels_dragged(self, *_: object) -> None:
        # The operator took the levels by hand: auto-levels stays off until asked again.
        self.auto_levels = False

    def set_auto_levels(self, on: bool = True) -> None:
        self.auto_levels = on
        self._auto_generation += 1  # the next levels found apply at once

    def reset_zoom(self) -> None:
        h, w = self.shape
        self.view.setRange(QRectF(0, 0, w, h), padding=0.0)

    # ------------------------------------------------------------------ overlays
    def show_status(self, status: CameraStatus) -> None:
        """Draw the search window at the ROI, the box and rim at the measured peak, and the
        GPS cross at the projected drone position."""
        self.show_gps(status.gps_xy)
        roi = status.roi_xy
        self.search_rect.setVisible(roi is not None)
        if roi is not None:
            self.search_rect.setRect(square_around(roi[0], roi[1], self.config.search_px))
        last = status.last.result if status.last is not None else None
        has_peak = roi is not None and last is not None
        for item in (self.box_rect, self.rim_inner_rect, self.peak_rect):
            item.setVisible(has_peak)
        small = has_peak and self.box_screen_px() < MIN_BOX_SCREEN_PX
        self.box_marker.setVisible(small)
        if has_peak:
            box = self.config.box_px
            self.box_rect.setRect(square_around(last.peak_x, last.peak_y, box))
            self.rim_inner_rect.setRect(square_around(last.peak_x, last.peak_y, box - 2))
            self.peak_rect.setRect(square_around(last.peak_x, last.peak_y, 1))
            if small:
                self.box_marker.centre_on(last.peak_x + 0.5, last.peak_y + 0.5)
        idle = time.monotonic() - self._pointer_s > LOUPE_FOLLOWS_POINTER_S
        if idle and roi is not None and self.graphics.viewport().width() >= LOUPE_ON_TRACK_MIN_PX:
            at = (last.peak_x, last.peak_y) if has_peak else roi
            self.show_loupe(*at)  # the pointer is elsewhere: the loupe on the track
        elif idle and self.loupe.isVisible() and roi is None:
            self.loupe.setVisible(False)

    def box_screen_px(self) -> float:
        """How wide the measured box is on the screen now (zoom included), in pixels."""
        a = self.view.mapViewToScene(QPointF(0.0, 0.0))
        b = self.view.mapViewToScene(QPointF(float(self.config.box_px), 0.0))
        return abs(b.x() - a.x())

    def set_palette(self, name: str) -> None:
        """Draw the image in palette ``name`` (:data:`PALETTES`) over the current levels."""
        if name not in PALETTES:
            raise ValueError(f"unknown palette {name!r} (known: {', '.join(PALETTES)})")
        self.palette = name
        self.histogram.gradient.restoreState({"mode": "rgb", "ticks": PALETTES[name]})

    def show_gps(self, xy: tuple[float, float] | None) -> None:
        """The GPS cross at image coordinates ``xy`` (pixel centres on integers, as
        :func:`snrmon.acquisition.geo.projection.project_enu` gives them); hidden for None or
        NaN."""
        ok = xy is not None and all(math.isfinite(v) for v in xy)
        self.gps_marker.setVisible(ok)
        if ok:
            self.gps_marker.centre_on(xy[0] + 0.5, xy[1] + 0.5)  # pixel c spans [c, c+1)

    # ------------------------------------------------------------------ clicks
    def _scene_clicked(self, event) -> None:
        if event.button() != Qt.MouseButton.LeftButton or event.double():
            return
        pos = event.scenePos()
        if not self.view.sceneBoundingRect().contains(pos):
            return
        self.click_at_scene(pos)
        event.accept()

    def _scene_moved(self, pos: QPointF) -> None:
        value = self.value_at_scene(pos)
        if value is not None:
            self._pointer_s = time.monotonic()
            self.show_loupe(value[0], value[1])
            self.pointed.emit(self.camera, *value)

    def show_loupe(self, x: int, y: int) -> None:
        """The loupe around image pixel (x, y) of the shown frame, in its colours."""
        pixels = self.image.image
        if pixels is None or pixels.ndim != 2:
            return
        lut = self.image.lut(pixels, 256) if callable(self.image.lut) else self.image.lut
        self.loupe.show_around(loupe_rgb(pixels, x, y, self.histogram.getLevels(), lut), (x, y))
        # in the corner away from the pixel, so the loupe never covers what it magnifies
        port = self.graphics.viewport()
        on_right = self.viewport_pos_of_pixel(x, y).x() > port.width() / 2
        self.loupe.move(6 if on_right else port.width() - self.loupe.width() - 6, 6)
        self.loupe.raise_()

    def value_at_scene(self, scene_pos: QPointF) -> tuple[int, int, float] | None:
        """(column, row, DN) of the shown frame's pixel at a scene position; None off it."""
        pt = self.view.mapSceneToView(scene_pos)
        x, y = pixel_at(pt.x(), pt.y())
        pixels = self.image.image
        if pixels is None or not (0 <= y < pixels.shape[0] and 0 <= x < pixels.shape[1]):
            return None
        return x, y, float(pixels[y, x])

    def click_at_scene(self, scene_pos: QPointF) -> tuple[int, int] | None:
        """Map a scene position to a pixel and emit :attr:`roi_clicked` if it is on the image."""
        pt = self.view.mapSceneToView(scene_pos)
        x, y = pixel_at(pt.x(), pt.y())
        h, w = self.shape
        if not (0 <= x < w and 0 <= y < h):
            return None
        self.roi_clicked.emit(self.camera, x, y)
        return x, y

    def viewport_pos_of_pixel(self, x: int, y: int) -> QPoint:
        """Where pixel (x, y)'s centre is in the graphics widget's viewport (for tests/tools)."""
        scene = self.view.mapViewToScene(QPointF(x + 0.5, y + 0.5))
        return self.graphics.mapFromScene(scene)
