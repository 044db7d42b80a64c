"""The simulated drone's outline as the cameras see it: body, arms and motor pods, no blades.

The paper characterises each drone by two numbers (section 3): the small dimension, the square
root of the segmented outline's area, and the large one, the square root of the area of the
box around the body without the blades. The twin renders a shape, not those numbers: a
:class:`Silhouette` is a union of ellipses and axis-aligned rectangles in metres (x right, y
up, the origin at the area centroid), scaled so that its area is small^2 and its bounding box
large^2 exactly. Seen from behind as it flies out, a quadcopter is a body between two arms that
end in motor pods. With the paper's numbers there is little room: the outline is 44 % of the
Phantom's box and 30 % of the Inspire's, so the twin's drone is two crossing bars, the body
spanning the box's height and the arms its width, about 6 cm thick (the thickness is solved for
the area): at the close stop (37 m, 1.85 cm per MWIR pixel) that is 3.2 px, which the
segmentation's 3 x 3 opening keeps, as it kept the real arms. Thinner parts (a body between
pods, legs) would be opened away and the segmented box would lose them.

:meth:`Silhouette.coverage` rasterises it onto a fine grid (the fraction of each cell inside,
exactly), which the renderer convolves with the camera's pixel response
(:mod:`snrmon.sim.optics`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Part:
    """An axis-aligned rectangle: centre (x, y) and full width and height [m]."""

    x_m: float
    y_m: float
    w_m: float
    h_m: float

    @property
    def edges(self) -> tuple[float, float, float, float]:
        return (
            self.x_m - 0.5 * self.w_m,
            self.y_m - 0.5 * self.h_m,
            self.x_m + 0.5 * self.w_m,
            self.y_m + 0.5 * self.h_m,
        )

    def intersection(self, other: Part) -> Part | None:
        a, b = self.edges, other.edges
        x0, y0, x1, y1 = max(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), min(a[3], b[3])
        if x1 <= x0 or y1 <= y0:
            return None
        return Part(0.5 * (x0 + x1), 0.5 * (y0 + y1), x1 - x0, y1 - y0)


def _overlap(lo: np.ndarray, hi: np.ndarray, a: float, b: float) -> np.ndarray:
    return np.clip(np.minimum(hi, b) - np.maximum(lo, a), 0.0, None)


@dataclass(frozen=True)
class Silhouette:
    """A drone outline (module docstring); build with :func:`quadcopter`. Its parts may
    overlap two at a time (the union's coverage is exact by inclusion-exclusion)."""

    name: str
    parts: tuple[Part, ...]
    bbox_m: tuple[float, float, float, float]  # x0, y0, x1, y1

    @property
    def width_m(self) -> float:
        return self.bbox_m[2] - self.bbox_m[0]

    @property
    def height_m(self) -> float:
        return self.bbox_m[3] - self.bbox_m[1]

    @property
    def large_m(self) -> float:
        """Square root of the bounding box's area (the paper's large dimension)."""
        return math.sqrt(self.width_m * self.height_m)

    def _signed_parts(self) -> list[tuple[float, Part]]:
        out = [(1.0, p) for p in self.parts]
        for i, a in enumerate(self.parts):
            for b in self.parts[i + 1 :]:
                both = a.intersection(b)
                if both is not None:
                    out.append((-1.0, both))
        return out

    def area_m2(self) -> float:
        """The outline's area (exact)."""
        return float(sum(sign * p.w_m * p.h_m for sign, p in self._signed_parts()))

    def coverage(self, cell_m: float, dx_m: float = 0.0, dy_m: float = 0.0) -> np.ndarray:
        """Fraction of each cell of a grid of pitch ``cell_m`` inside the outline (exact: the
        rectangles' overlaps with the cells), rows = -y (image rows grow downward); the origin
        (the area centroid, shifted by dx, dy) lies at the centre of the middle cell. The array
        has an odd size on both axes."""
        x0, y0, x1, y1 = self.bbox_m
        reach = max(abs(x0 + dx_m), abs(x1 + dx_m), abs(y0 + dy_m), abs(y1 + dy_m))
        n = 2 * math.ceil(reach / cell_m + 1) + 1
        lo = (np.arange(n) - n // 2 - 0.5) * cell_m
        hi = lo + cell_m
        out = np.zeros((n, n))
        for sign, p in self._signed_parts():
            e = p.edges
            ox = _overlap(lo, hi, e[0] + dx_m, e[2] + dx_m)
            # rows run downward: row r spans y in [-hi, -lo]
            oy = _overlap(-hi, -lo, e[1] + dy_m, e[3] + dy_m)
            out += sign * np.outer(oy, ox)
        return np.clip(out / (cell_m * cell_m), 0.0, 1.0)


def _parts(width: float, height: float, thick: float) -> tuple[Part, ...]:
    """The body, a bar of ``thick`` spanning the box's height, and the arms, a bar spanning
    its width a little above the middle; origin at the box centre."""
    return (
        Part(0.0, 0.0, thick, height),
        Part(0.0, 0.1 * height, width, thick),
    )


def quadcopter(name: str, small_m: float, large_m: float, aspect: float = 1.0) -> Silhouette:
    """A quadcopter outline whose area is ``small_m``^2 and whose box is ``aspect`` (width /
    height) with area ``large_m``^2; the bars' thickness is solved for the area."""
    if not 0 < small_m < large_m:
        raise ValueError(f"need 0 < small < large, got {small_m}, {large_m}")
    height = large_m / math.sqrt(aspect)
    width = large_m * math.sqrt(aspect)
    box = (-0.5 * width, -0.5 * height, 0.5 * width, 0.5 * height)
    # exact: two crossing bars of thickness t cover t (w + h) - t^2
    thick = 0.5 * (width + height) - math.sqrt(0.25 * (width + height) ** 2 - small_m**2)
    s = Silhouette(name, _parts(width, height, thick), box)
    # put the area centroid at the origin (the drone's position is its light's centre)
    cy = 0.1 * height * (thick * width - thick * thick) / small_m**2
    parts = tuple(replace(p, y_m=p.y_m - cy) for p in s.parts)
    return Silhouette(name, parts, (box[0], box[1] - cy, box[2], box[3] - cy))


# The paper gives the two areas (section 3), not the shape. Both boxes are taken square: for a
# given box area, crossing bars are thickest in a square box.
SILHOUETTES = {
    "uav1": lambda: quadcopter("uav1", 0.157, 0.238, aspect=1.0),
    "uav2": lambda: quadcopter("uav2", 0.201, 0.367, aspect=1.0),
}


def silhouette_for(target) -> Silhouette:
    """The twin's outline of a model target (``model.target.Target``): a built-in drone
    (uav1, uav2), else a quadcopter of the target's two dimensions in a square box."""
    make = SILHOUETTES.get(str(getattr(target, "name", "")).lower())
    s = make() if make is not None else None
    if s is None or not (
        math.isclose(s.area_m2() ** 0.5, target.small_m, rel_tol=5e-3)
        and math.isclose(s.large_m, target.large_m, rel_tol=1e-6)
    ):  # another target, or a preset whose dimensions were changed: its own quadcopter
        return quadcopter(target.name, target.small_m, target.large_m, 1.0)
    return s
