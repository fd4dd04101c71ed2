"""Color landmarks: each UGV's roof label found by its HSV range; blob centres out.

Hue ranges are in OpenCV's 0-179 scale; red wraps around 0, so it is two ranges. Saturation and value
floors keep grey ground and shadows out; blobs smaller than ``min_area_px`` (noise) or larger than
``max_area_px`` (not a roof label) are ignored, and of several blobs of one color the largest wins.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = ["ColorRange", "DEFAULT_COLORS", "LandmarkConfig", "detect_landmarks", "LabelCandidate", "label_candidates",
           "MAX_CANDIDATES"]

MAX_CANDIDATES = 4   # label-sized blobs of one color kept per frame (largest first)


@dataclass(frozen=True, slots=True)
class ColorRange:
    hue_ranges: tuple[tuple[int, int], ...]   # inclusive, 0-179
    s_min: int = 120
    v_min: int = 90


DEFAULT_COLORS = {
    "red": ColorRange(((0, 8), (172, 179))),
    "yellow": ColorRange(((22, 35),)),
    "green": ColorRange(((45, 80),)),
    "cyan": ColorRange(((85, 100),)),
    "blue": ColorRange(((105, 130),)),
    "magenta": ColorRange(((140, 165),)),
}


@dataclass(frozen=True, slots=True)
class LandmarkConfig:
    colors: dict = field(default_factory=lambda: dict(DEFAULT_COLORS))
    min_area_px: float = 6.0
    max_area_px: float = 20_000.0


@dataclass(frozen=True, slots=True)
class LabelCandidate:
    """A label-sized blob of one roof color: where, and how many pixels."""

    color: str
    x_px: float
    y_px: float
    area_px: float


def _color_mask(hsv: np.ndarray, cr: ColorRange) -> np.ndarray:
    mask = None
    for lo, hi in cr.hue_ranges:
        m = cv2.inRange(hsv, (lo, cr.s_min, cr.v_min), (hi, 255, 255))
        mask = m if mask is None else mask | m
    return mask


def label_candidates(frame_bgr: np.ndarray, cfg: LandmarkConfig, wanted: tuple[str, ...] | None = None,
                     windows: dict[str, tuple[int, int, int, int]] | None = None) -> list[LabelCandidate]:
    """Every label-sized blob (``min_area_px`` to ``max_area_px``) of each wanted color, up to
    ``MAX_CANDIDATES`` per color, largest first. ``windows``: color -> (x0, y0, x1, y1) in pixels: that
    color is looked for only there (a UGV tracked from frame to frame; the whole frame is converted to
    HSV only when some wanted color has no window)."""
    windows = windows or {}
    h_img, w_img = frame_bgr.shape[:2]
    names = list(wanted or tuple(cfg.colors))
    for name in names:
        if name not in cfg.colors:
            raise KeyError(f"no HSV range for color {name!r}; known: {', '.join(cfg.colors)}")
    full = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2HSV) if any(n not in windows for n in names) else None
    out: list[LabelCandidate] = []
    for name in names:
        cr = cfg.colors[name]
        if name in windows:
            x0, y0, x1, y1 = windows[name]
            x0, y0, x1, y1 = max(0, int(x0)), max(0, int(y0)), min(w_img, int(x1)), min(h_img, int(y1))
            if x1 <= x0 or y1 <= y0:
                continue
            hsv = full[y0:y1, x0:x1] if full is not None else cv2.cvtColor(frame_bgr[y0:y1, x0:x1], cv2.COLOR_BGR2HSV)
        else:
            x0, y0, hsv = 0, 0, full
        mask = _color_mask(hsv, cr)
        if cv2.countNonZero(mask) < cfg.min_area_px:
            continue
        bx, by, bw, bh = cv2.boundingRect(mask)   # labelling only where the color is: ~20x faster
        n, _, stats, cents = cv2.connectedComponentsWithStats(mask[by:by + bh, bx:bx + bw], connectivity=8)
        found = [(int(stats[i, cv2.CC_STAT_AREA]), i) for i in range(1, n)
                 if cfg.min_area_px <= stats[i, cv2.CC_STAT_AREA] <= cfg.max_area_px]
        for area, i in sorted(found, reverse=True)[:MAX_CANDIDATES]:
            out.append(LabelCandidate(name, float(cents[i][0]) + bx + x0, float(cents[i][1]) + by + y0, float(area)))
    return out


def detect_landmarks(frame_bgr: np.ndarray, cfg: LandmarkConfig, wanted: tuple[str, ...] | None = None
                     ) -> dict[str, tuple[float, float]]:
    """color name -> (x_px, y_px) centre of its largest blob, for the colors present (no other knowledge)."""
    out: dict[str, tuple[float, float]] = {}
    for c in label_candidates(frame_bgr, cfg, wanted):
        out.setdefault(c.color, (c.x_px, c.y_px))   # largest first
    return out
