"""The tracked object's motion: an alpha-beta (constant-velocity) filter on its centroid.

Per frame the filter predicts ``p + v`` (pixels; x = column, y = row). A measured centroid ``z``
corrects it: ``r = z - prediction``, ``p = prediction + alpha r``, ``v = v + beta r``, the speed
then clamped to ``max_speed_px`` per frame. A frame without a measurement coasts: ``p = p + v``
and the velocity decays by ``coast_decay`` (a drone that is not seen is more likely hovering
than flying on in a straight line for ever). Frames dropped before they reached the tracker
(:meth:`advance`) move it on without decay: the drone was not missed, just not looked for. The
whole state is a few floats
(:meth:`snapshot` / :meth:`restore`, JSON-able and exact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class MotionConfig:
    alpha: float = 0.7
    beta: float = 0.2
    max_speed_px: float = 8.0
    coast_decay: float = 0.8

    def __post_init__(self) -> None:
        if not (0 < self.alpha <= 1 and 0 <= self.beta <= 1 and 0 <= self.coast_decay <= 1):
            raise ValueError(
                f"need 0 < alpha <= 1, 0 <= beta <= 1, 0 <= coast_decay <= 1; got "
                f"{self.alpha}, {self.beta}, {self.coast_decay}"
            )
        if not self.max_speed_px > 0:
            raise ValueError(f"max_speed_px must be > 0, got {self.max_speed_px}")


class MotionModel:
    """Position and velocity of the tracked object (module docstring)."""

    def __init__(self, config: MotionConfig | None = None) -> None:
        self.config = config or MotionConfig()
        self.x = self.y = self.vx = self.vy = 0.0
        self.ready = False

    def reset(self, x: float, y: float, vx: float = 0.0, vy: float = 0.0) -> None:
        self.x, self.y = float(x), float(y)
        self.vx, self.vy = float(vx), float(vy)
        self._clamp()
        self.ready = True

    def predict(self) -> tuple[float, float]:
        """Where the object is expected on the next frame."""
        return self.x + self.vx, self.y + self.vy

    def update(self, zx: float, zy: float) -> None:
        """Correct with the measured centroid of the next frame."""
        if not self.ready:
            self.reset(zx, zy)
            return
        c = self.config
        px, py = self.predict()
        rx, ry = zx - px, zy - py
        self.x, self.y = px + c.alpha * rx, py + c.alpha * ry
        self.vx += c.beta * rx
        self.vy += c.beta * ry
        self._clamp()

    def coast(self) -> None:
        """A frame without a measurement."""
        self.x, self.y = self.predict()
        d = self.config.coast_decay
        self.vx *= d
        self.vy *= d

    def advance(self, frames: int, bounds: tuple[float, float] | None = None) -> None:
        """``frames`` frames that were never seen (dropped): ``p += v`` each, no decay; the
        position is kept within ``bounds`` (columns, rows: the image) when given."""
        if frames <= 0:
            return
        self.x += frames * self.vx
        self.y += frames * self.vy
        if bounds is not None:
            self.x = min(max(self.x, 0.0), bounds[0] - 1.0)
            self.y = min(max(self.y, 0.0), bounds[1] - 1.0)

    @property
    def speed(self) -> float:
        return math.hypot(self.vx, self.vy)

    def _clamp(self) -> None:
        s = self.speed
        m = self.config.max_speed_px
        if s > m:
            self.vx *= m / s
            self.vy *= m / s

    def snapshot(self) -> dict:
        return {"x": self.x, "y": self.y, "vx": self.vx, "vy": self.vy, "ready": self.ready}

    def restore(self, state: dict) -> None:
        self.x, self.y = float(state["x"]), float(state["y"])
        self.vx, self.vy = float(state["vx"]), float(state["vy"])
        self.ready = bool(state["ready"])
