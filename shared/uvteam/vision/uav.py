"""The UAV's pixel pipeline: one frame in, color landmarks and motion blobs out. No I/O, no clock.

:class:`UavVision` holds the motion detector's state and sizes its bounds from the altitude the
caller passes with each frame (the autopilot's height above ground): blob area bounds (at least
``min_crowd_m2`` of moving ground, about three people: a lone walker is not a crowd), the kernel that
joins a crowd's members into one blob, and the processing scale (full resolution when a person would
be under 3 pixels at half scale, otherwise half). The detector is rebuilt, losing its one frame of
history, only when the altitude changes by more than 15 %. Color landmarks are found first and
carved out of the motion blobs that hold them (:meth:`MotionDetector.update`), so a UGV passing
through a crowd leaves the crowd's blob intact beside its own. Color-label area bounds come from the
label's side and the altitude too, so a shrub of the right hue but the wrong size is not a landmark.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..blobs import Blobs, Landmarks
from .label_tracks import LabelTracks
from .landmarks import LabelCandidate, LandmarkConfig, label_candidates
from .motion import MotionConfig, MotionDetector, Registration, bounds_for_altitude

__all__ = ["UavVisionConfig", "UavVision", "UavFrameResult", "LabelExpectation", "landmark_config"]

FULL_RES_BELOW_PERSON_PX = 3.0   # process at full resolution when a person would be smaller than this
VELOCITY_REACH_PX = 8.0          # a walker's velocity is measured over no longer than it takes to move this far
MIN_VELOCITY_LAG_S = 0.1         # ... (Lucas-Kanade finds a walker only this near where it is sought), but at least this
RECONFIGURE_ALTITUDE_CHANGE = 0.15  # rebuild the detector when the altitude changes by more than this fraction
LABEL_AREA_RANGE = (0.25, 4.0)   # a roof label's blob is this fraction to multiple of the label's area
LABEL_AREA_SLACK_PX = 25.0       # ... plus this much (blur and edge pixels of a small label)
MIN_LABEL_AREA_PX = 3.0
TRACK_KEEP_S = 0.5               # a label found this recently is looked for near where it was
MAX_UGV_SPEED_M_S = 6.0          # ... within the distance a UGV can cover since, plus a label's size
ACQUIRE_EVERY = 30               # every this many frames (3 s at 10 Hz) the whole frame is searched, not only windows,
                                 # unless every color has a prediction (nothing outside its window would be taken)


@dataclass(frozen=True, slots=True)
class UavVisionConfig:
    focal_px: float
    colors: tuple[str, ...]                  # the roof colors to look for
    label_side_m: float = 1.0
    vehicle_radius_m: float = 2.0             # a UGV with its shadow, around its roof label
    person_m: float = 0.5
    crowd_spacing_m: float = 4.0              # members this far apart still make one blob
    crowd_gap_m: float = 1.5                  # two crowds, each big enough, this far apart are two: 2 m between
                                              # members (the mingling distance of the scoring) less a person
    crowd_max_m: float = 40.0
    min_crowd_m2: float = 6.0                 # moving ground area of about three people in the history
    walk_max_m_s: float = 3.2                 # the fastest crowd whose walkers' velocity is measured (motion step 8)
    motion: MotionConfig = field(default_factory=lambda: MotionConfig(speckle="neighbours", max_corners=200, lk_window_px=15,
                                                                      gradient_gain=0.12, stray_reach=1.0, box_k=5.0,
                                                                      lag_s=0.2, velocity_lag_s=0.5))
    landmarks: LandmarkConfig = field(default_factory=LandmarkConfig)

    def __post_init__(self) -> None:
        if not self.focal_px > 0:
            raise ValueError(f"focal_px must be > 0, got {self.focal_px}")
        unknown = [c for c in self.colors if c not in self.landmarks.colors]
        if unknown:
            raise ValueError(f"no HSV range for colors {unknown}; known: {', '.join(self.landmarks.colors)}")


@dataclass(frozen=True, slots=True)
class LabelExpectation:
    """Where a UGV's roof label must be, from its fix through the camera's pose."""

    xy_px: tuple[float, float]
    radius_px: float              # 3 sigma of the prediction
    moving: bool                  # the UGV reports it moves: its label rides on motion
    velocity_px_s: tuple[float, float] | None = None   # the UGV's reported velocity in this frame's pixels
    velocity_stamp_s: float | None = None              # ... as measured then (its fix's time; None: now)


@dataclass(frozen=True, slots=True)
class UavFrameResult:
    stamp_s: float
    landmarks: Landmarks          # by roof color
    blobs: Blobs                  # ``ugv``: the roof color of the vehicle a blob is, or ""
    registration: Registration    # the camera motion the blobs rest on
    refused: dict = field(default_factory=dict)   # color -> why its label-colored blobs were not taken
    warming: bool = False         # the motion detector's lagged test not yet run: vehicles' blobs only


def landmark_config(cfg: UavVisionConfig, alt_agl_m: float) -> LandmarkConfig:
    """Color-blob area bounds for a roof label of ``label_side_m`` seen from this altitude: a quarter to
    four times its area, so a walker in a shirt of a label's color (a tenth of it) is not a landmark."""
    label_px2 = (cfg.label_side_m * cfg.focal_px / alt_agl_m) ** 2
    lo, hi = LABEL_AREA_RANGE
    return replace(cfg.landmarks, min_area_px=max(MIN_LABEL_AREA_PX, lo * label_px2),
                   max_area_px=hi * label_px2 + LABEL_AREA_SLACK_PX)


class UavVision:
    def __init__(self, cfg: UavVisionConfig) -> None:
        self.cfg = cfg
        self._alt_m: float | None = None
        self._motion: MotionDetector | None = None
        self._lm_cfg = cfg.landmarks
        self._tracked: dict[str, tuple[float, float, float]] = {}   # color -> (stamp, x, y) of its last label
        self._tracks = LabelTracks()
        self._frames = 0

    def _configure(self, alt_agl_m: float) -> None:
        cfg = self.cfg
        person_px = cfg.person_m * cfg.focal_px / alt_agl_m
        full = person_px * cfg.motion.process_scale < FULL_RES_BELOW_PERSON_PX
        base = replace(cfg.motion, process_scale=1.0 if full else cfg.motion.process_scale)
        mc = bounds_for_altitude(alt_agl_m, cfg.focal_px, person_m=cfg.person_m, spacing_m=cfg.crowd_spacing_m,
                                 gap_m=cfg.crowd_gap_m, crowd_max_m=cfg.crowd_max_m, base=base)
        mc = replace(mc, min_area_px=max(mc.min_area_px, cfg.min_crowd_m2 * (cfg.focal_px / alt_agl_m) ** 2))
        if mc.velocity_lag_s > 0:   # over no longer than the fastest walker takes to leave the search's reach
            reach_s = VELOCITY_REACH_PX / (cfg.walk_max_m_s * cfg.focal_px / alt_agl_m)
            mc = replace(mc, velocity_lag_s=min(mc.velocity_lag_s, max(reach_s, MIN_VELOCITY_LAG_S)))
        self._motion = MotionDetector(mc)
        self._lm_cfg = landmark_config(cfg, alt_agl_m)
        self._alt_m = alt_agl_m

    @property
    def motion_config(self) -> MotionConfig | None:
        return None if self._motion is None else self._motion.cfg

    def update(self, frame_bgr: np.ndarray, stamp_s: float, alt_agl_m: float,
               expect: dict[str, LabelExpectation] | None = None) -> UavFrameResult:
        """One frame: roof labels (each color's label-sized blobs, the one that agrees with what is known
        of its UGV: :meth:`_choose`), then motion blobs with the labelled vehicles carved out."""
        if not (np.isfinite(alt_agl_m) and alt_agl_m > 1.0):
            raise ValueError(f"alt_agl_m must be a finite height above 1 m, got {alt_agl_m}")
        if self._alt_m is None or abs(alt_agl_m - self._alt_m) > RECONFIGURE_ALTITUDE_CHANGE * self._alt_m:
            self._configure(alt_agl_m)
        px_per_m = self.cfg.focal_px / alt_agl_m
        expect = expect or {}
        windows = self._windows(stamp_s, px_per_m, expect)
        cands = label_candidates(frame_bgr, self._lm_cfg, self.cfg.colors, windows)
        self._motion.register(frame_bgr, stamp_s)   # so that "on what moved" follows a jolting camera
        self._tracks.carry(self._motion.carry_forward)
        chosen, refused = self._choose(cands, stamp_s, px_per_m, expect)
        lms = Landmarks.from_dict(chosen)
        motion = self._motion.update(frame_bgr, stamp_s, lms.xy_px, self.cfg.vehicle_radius_m * px_per_m, lms.ugv)
        blobs = replace(motion.blobs, ugv=tuple(lms.ugv[c] if c >= 0 else "" for c in motion.carved))
        return UavFrameResult(stamp_s, lms, blobs, motion.registration, refused, motion.warming)

    def _reach_px(self, stamp_s: float, since_s: float, px_per_m: float) -> float:
        return (MAX_UGV_SPEED_M_S * max(stamp_s - since_s, 0.0) + 2.0 * self.cfg.label_side_m) * px_per_m

    def _windows(self, stamp_s: float, px_per_m: float, expect: dict[str, LabelExpectation]) -> dict:
        """Where to look for each color this frame: around its expected and its last place (the whole
        frame for a color with neither, and every ``ACQUIRE_EVERY`` frames unless every color has a
        prediction: :meth:`_choose` takes a predicted color's label only within the prediction's radius,
        which its window holds, so the whole frame adds nothing but its cost, 21-29 ms on real imagery,
        0.7-1.0 ms a frame on average; and on imagery with label hues about, it keeps a color's four
        largest blobs, which can leave out what the window holds: real-alt120-lm6 seed 1's first 5 s, 102
        of 306 windows held label-sized blobs the whole frame's search did not return)."""
        self._frames += 1
        if self._frames % ACQUIRE_EVERY == 1 and not all(c in expect for c in self.cfg.colors):
            return {}
        out = {}
        for color in self.cfg.colors:
            boxes = []
            if color in expect:
                (x, y), r = expect[color].xy_px, expect[color].radius_px
                boxes.append((x - r, y - r, x + r, y + r))
            last = self._tracked.get(color)
            if last is not None and stamp_s - last[0] <= TRACK_KEEP_S:
                r = self._reach_px(stamp_s, last[0], px_per_m)
                boxes.append((last[1] - r, last[2] - r, last[1] + r, last[2] + r))
            if not boxes:
                return {}           # a color to acquire: the whole frame is converted anyway
            b = np.array(boxes)
            out[color] = (b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max())
        return out

    def _choose(self, cands: list[LabelCandidate], stamp_s: float, px_per_m: float,
                expect: dict[str, LabelExpectation]) -> tuple[dict[str, tuple[float, float]], dict[str, str]]:
        """Each color's label. With a prediction for any UGV: of its label-sized blobs within the prediction's
        3 sigma and, when the UGV moves, on what moved, the one whose track has moved as its UGV reports
        (:mod:`uvteam.vision.label_tracks`); a color without a prediction this frame keeps a confirmed track
        only. With none at all (no pose, or no fix yet): the one nearest where the label was last frame, else
        (acquiring) the largest on what moved, else the largest. A color whose blobs all fail is not seen
        this frame, and why is said."""
        chosen: dict[str, tuple[float, float]] = {}
        refused: dict[str, str] = {}
        all_xy = np.array([[c.x_px, c.y_px] for c in cands], float).reshape(-1, 2)
        all_moved = self._motion.moved_near(all_xy) if self._motion is not None and len(cands) else None
        rows: dict[str, list[int]] = {}
        for k, c in enumerate(cands):
            rows.setdefault(c.color, []).append(k)
        for color in self.cfg.colors:
            idx = rows.get(color, [])
            xy = all_xy[idx]
            moved = all_moved[idx] if all_moved is not None and idx else None
            e = expect.get(color)
            if expect:
                ok = np.ones(len(xy), bool)
                if e is not None and len(xy):
                    ok = np.hypot(*(xy - e.xy_px).T) <= e.radius_px
                    if not ok.any():
                        refused[color] = "far_from_fix"
                    elif e.moving and moved is not None:
                        if not (ok & moved).any():
                            refused[color] = "not_moving"
                        ok &= moved
                v = None if e is None or e.velocity_px_s is None else np.array(e.velocity_px_s, float)
                k, why = self._tracks.update(color, stamp_s, xy[ok], v, px_per_m,
                                             None if e is None else np.array(e.xy_px, float), start=e is not None,
                                             velocity_stamp_s=None if e is None else e.velocity_stamp_s)
                if k is not None:
                    chosen[color] = tuple(map(float, xy[ok][k]))
                elif why and color not in refused:
                    refused[color] = why
                continue
            if not len(xy):
                continue
            last = self._tracked.get(color)
            if last is not None and stamp_s - last[0] <= TRACK_KEEP_S:
                d = np.hypot(xy[:, 0] - last[1], xy[:, 1] - last[2])
                if d.min() > self._reach_px(stamp_s, last[0], px_per_m):
                    refused[color] = "jumped"
                    continue
                k = int(np.argmin(d))
            else:
                k = int(np.flatnonzero(moved)[0]) if moved is not None and moved.any() else 0   # largest first
            chosen[color] = (float(xy[k, 0]), float(xy[k, 1]))
        for color, (x, y) in chosen.items():
            self._tracked[color] = (stamp_s, x, y)
        return chosen, refused
