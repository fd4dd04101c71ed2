"""What the UAV sees, drawn: a camera frame with its detections and the localizer's crowds, as in the
paper's Figs. 3-6. Pure: an image and messages in, a new image out (the input is not touched).

- every motion blob boxed: a crowd's blob (no UGV in it) in red, a UGV's blob in its UGV's colour with
  its id;
- every roof-label landmark: a ring at its centre and the UGV id;
- every crowd of the localizer's message for this frame: its id, lat/lon and 95 % radius in a list at
  the top left, and a tag at the crowd in the image where it can be placed (:func:`place_crowds`:
  the frame's landmarks against the UGVs' fixes give the ground-to-image transform; with fewer than
  four such pairs the crowds are listed only);
- a header: the UAV, frame number, capture time (UTC), height above ground, the fit quality.

    img = annotate(frame_bgr, detections, crowds, ugv_lat_lon={"ugv1": (31.4851, -111.5441), ...})
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import numpy as np

from ..geo import LocalFrame
from ..homography import fit_homography
from ..messages import Crowds, Detections

__all__ = ["annotate", "place_crowds", "CrowdTag", "CROWD_BGR", "ugv_bgr"]

CROWD_BGR = (0, 0, 255)             # a crowd's blob: pure red, so a test can find it in a JPEG
TAG_BGR = (0, 200, 255)             # a crowd's tag: amber
LANDMARK_BGR = (0, 255, 255)        # roof labels: yellow
_UGV_PALETTE = ((255, 160, 0), (0, 200, 0), (255, 0, 200), (255, 255, 0), (160, 80, 255), (0, 128, 255))
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def ugv_bgr(ugv: str) -> tuple[int, int, int]:
    """A UGV's drawing colour, the same in every frame (never the crowds' red)."""
    return _UGV_PALETTE[sum(ugv.encode()) % len(_UGV_PALETTE)]


@dataclass(frozen=True, slots=True)
class CrowdTag:
    crowd_id: int
    lat_deg: float
    lon_deg: float
    radius95_m: float
    quality: str
    xy_px: tuple[float, float] | None      # where the crowd is in the image; None when it cannot be placed
    unseen_s: float = 0.0                  # > 0: not seen in this frame, where its walk takes it


def place_crowds(det: Detections, crowds: Crowds | None,
                 ugv_lat_lon: Mapping[str, tuple[float, float]] | None) -> list[CrowdTag]:
    """Each crowd with its pixel position: the ground-to-image transform fitted to the frame's landmarks
    (roof-label pixels) and the UGVs' positions (lat/lon, e.g. their latest fixes); None without four."""
    if crowds is None:
        return []
    xy = None
    pairs = [(det.landmarks.xy_px[i], ugv_lat_lon[u]) for i, u in enumerate(det.landmarks.ugv)
             if ugv_lat_lon and u in ugv_lat_lon]
    if len(pairs) >= 4 and crowds.crowds:
        px = np.array([p for p, _ in pairs], float)
        ll = np.array([g for _, g in pairs], float)
        frame = LocalFrame(float(ll[0, 0]), float(ll[0, 1]))
        e, n = frame.wgs84_to_ground(ll[:, 0], ll[:, 1])
        fit = fit_homography(px, np.column_stack([e, n]))
        if fit:
            ce, cn = frame.wgs84_to_ground(np.array([c.lat_deg for c in crowds.crowds]),
                                           np.array([c.lon_deg for c in crowds.crowds]))
            xy = fit.ground_to_px(np.column_stack([ce, cn]))
    out = []
    for i, c in enumerate(crowds.crowds):
        p = None
        if xy is not None and np.isfinite(xy[i]).all() and -det.width_px <= xy[i][0] <= 2 * det.width_px \
                and -det.height_px <= xy[i][1] <= 2 * det.height_px:
            p = (float(xy[i][0]), float(xy[i][1]))
        out.append(CrowdTag(c.crowd_id, c.lat_deg, c.lon_deg, c.radius95_m, c.quality, p, c.unseen_s))
    return out


def _text(img: np.ndarray, s: str, org: tuple[int, int], scale: float, color, thick: int = 1) -> None:
    """Text with a dark outline, readable on sand and on shadow."""
    cv2.putText(img, s, org, _FONT, scale, (0, 0, 0), thick + 2, cv2.LINE_AA)
    cv2.putText(img, s, org, _FONT, scale, color, thick, cv2.LINE_AA)


def annotate(img: np.ndarray, det: Detections, crowds: Crowds | None = None,
             ugv_lat_lon: Mapping[str, tuple[float, float]] | None = None, *, note: str = "") -> np.ndarray:
    """A copy of ``img`` (BGR, the frame ``det`` was detected on) with detections and crowds drawn."""
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"img: expected an HxWx3 BGR image, got shape {img.shape}")
    out = np.ascontiguousarray(img, dtype=np.uint8).copy()
    h, w = out.shape[:2]
    sx, sy = w / det.width_px, h / det.height_px         # detections are in the frame's own pixels
    scale = max(0.4, min(1.2, w / 1600))
    thick = 3 if w >= 960 else 2      # thin coloured lines do not survive 4:2:0 video
    for (x0, y0, x1, y1), ugv in zip(det.blobs.xyxy_px, det.blobs.ugv):
        p0, p1 = (int(round(x0 * sx)), int(round(y0 * sy))), (int(round(x1 * sx)), int(round(y1 * sy)))
        color = ugv_bgr(ugv) if ugv else CROWD_BGR
        cv2.rectangle(out, p0, p1, color, thick)
        if ugv:
            _text(out, ugv, (p0[0], max(p0[1] - 4, 12)), scale * 0.8, color)
    r = max(6, int(round(8 * scale)))
    for ugv, (x, y) in zip(det.landmarks.ugv, det.landmarks.xy_px):
        c = (int(round(x * sx)), int(round(y * sy)))
        cv2.circle(out, c, r, LANDMARK_BGR, thick, cv2.LINE_AA)
        _text(out, ugv, (c[0] + r + 2, c[1] + r + 2), scale * 0.7, LANDMARK_BGR)
    tags = place_crowds(det, crowds, ugv_lat_lon)
    for t in tags:
        if t.xy_px is None:
            continue
        c = (int(round(t.xy_px[0] * sx)), int(round(t.xy_px[1] * sy)))
        cv2.drawMarker(out, c, TAG_BGR, cv2.MARKER_CROSS, 2 * r, thick, cv2.LINE_AA)
        _text(out, f"#{t.crowd_id} {t.lat_deg:.6f}, {t.lon_deg:.6f}", (c[0] + r, c[1] - r), scale * 0.8, TAG_BGR)
    line = int(round(26 * scale + 6))
    stamp = time.strftime("%H:%M:%S", time.gmtime(det.stamp_s)) + f".{int(det.stamp_s * 10) % 10}"
    head = f"{det.vehicle} frame {det.frame_seq}  {stamp} UTC  {det.alt_agl_m:.0f} m AGL"
    if crowds is not None:
        head += f"  fit {crowds.quality}, {len(crowds.landmarks_used)} landmarks"
    if note:
        head += f"  {note}"
    cv2.rectangle(out, (0, 0), (w, line + 4), (0, 0, 0), -1)
    _text(out, head, (6, line - 4), scale * 0.8, (255, 255, 255))
    for i, t in enumerate(tags):
        _text(out, f"crowd #{t.crowd_id}: {t.lat_deg:.6f}, {t.lon_deg:.6f}  r95 {t.radius95_m:.1f} m  {t.quality}"
                   + (f"  unseen {t.unseen_s:.1f} s" if t.unseen_s > 0 else "")
                   + ("" if t.xy_px is not None else "  (not placed)"),
              (6, line * (i + 2)), scale * 0.75, TAG_BGR)
    if crowds is not None and not tags:
        _text(out, "no crowd", (6, line * 2), scale * 0.75, TAG_BGR)
    return out
