"""How the walkers in a motion blob move against the ground, from corners on them. Pure: no I/O, no clock.

A blob's centre drifts whenever walkers leave its pixels (ground of their own shade, a canopy, a vehicle's
blob over them) or join them, and a velocity fitted to its centres walks with that drift. The walkers' own
texture does not: corners found on them in this frame (on what moved, off the vehicles), followed back
``lag`` frames by pyramidal Lucas-Kanade (searched from where the camera's motion takes the ground under them:
a camera that moves many pixels in that time leaves only the walkers' own motion to find) and forward again (a
corner that does not come back within ``back_px`` is dropped), move as the walkers do (:func:`walkers_velocity`).
The camera's motion over those frames is taken out by the chained frame-to-frame homographies the motion
detector already fits, and what is left of it near the blob (those fits are made on a scaled copy) by the
median motion of the box's corners off what moved that did not move: the ground round the walkers. Of the
corners that moved more than ``moved_px``, the median motion over the time between the frames is the blob's
velocity in this frame's pixels, and the median absolute deviation over the square root of their count its
spread (1 sigma per axis, at least ``min_sigma_px_s``).

Lucas-Kanade finds a walker only within about a window of where it is sought, so the UAV pipeline measures over
no longer than the fastest walker it expects takes to move 8 px (:class:`uvteam.vision.uav.UavVisionConfig`:
0.16 s at 50 m, 0.19 s at 60 m, 0.38 s at 120 m, 0.5 s from 160 m): over 0.5 s, paper-fig7-alt50's crowd at
3.1 m/s (25 px) was measured at 0.27-0.34 of its speed.

Measured on the deployed path (`docs/velocity_check.py`: the localizer's ground velocity against the truth's crowd
velocity over the last 0.5 s; docs/results-worlds.md, session 51), tuning seeds: speed 0.94-0.98 of the truth's at
50-60 m (paper-fig7-alt50, paper-fig9-color-lm4, real-alt60-lm6), 0.92 at 120 m (real-alt120-lm6: corners where
walkers of 3-4 px meet the ground follow some of both); median absolute error 0.08-0.19 m/s per axis, RMS
0.12-0.45 m/s: heavy tails, in spells where few corners lie on walkers of little contrast, when the declared spread
is larger too (the error's median 0.12 m/s in the quarter of frames with the least spread, 0.66 in the tenth with
the most). :mod:`uvteam.crowds` step 10 weighs a crowd's velocity by that spread.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["VelocityConfig", "box_window", "walkers_velocity"]

MAD_SIGMA = 1.4826      # a normal distribution's sigma per median absolute deviation


@dataclass(frozen=True, slots=True)
class VelocityConfig:
    margin_px: float = 6.0          # corners are sought this far round the blob's box (full-resolution px)
    max_corners: int = 120          # per blob
    corner_quality: float = 0.005
    corner_min_distance_px: float = 3.0
    lk_window_px: int = 9
    lk_levels: int = 2
    back_px: float = 0.5            # forward-backward check
    moved_px: float = 2.0           # a corner that moved less than this against the ground over the lag is ground
    min_moved: int = 4              # fewer corners moved than this: not measured
    min_still: int = 5              # this many still corners correct the ground's motion near the blob
    min_sigma_px_s: float = 0.5

    def __post_init__(self) -> None:
        if not (self.margin_px >= 0 and self.max_corners >= 1 and self.lk_window_px >= 3 and self.lk_levels >= 0
                and self.back_px > 0 and self.moved_px >= 0 and self.min_moved >= 1 and self.min_still >= 1
                and self.min_sigma_px_s > 0):
            raise ValueError("velocity: margin_px, moved_px >= 0; max_corners, min_moved, min_still >= 1; "
                             "lk_window_px >= 3, lk_levels >= 0; back_px, min_sigma_px_s > 0")


def box_window(box_xyxy_px, margin_px: float, w: int, h: int) -> tuple[int, int, int, int]:
    """Where corners are sought round a blob's box (x0, y0, x1, y1): the box widened by ``margin_px`` to whole
    pixels (x1, y1 exclusive), inside a ``w`` x ``h`` frame. The motion detector's mask of what moved is drawn
    in these same windows (:func:`uvteam.vision.motion._full_res_mask`)."""
    x0, y0, x1, y1 = box_xyxy_px
    return (max(int(x0 - margin_px), 0), max(int(y0 - margin_px), 0),
            min(int(np.ceil(x1 + margin_px)) + 1, w), min(int(np.ceil(y1 + margin_px)) + 1, h))


def _lk_reach_px(cfg: VelocityConfig) -> int:
    """How far round a point pyramidal Lucas-Kanade reads the image: its window at the coarsest level, the
    pyramid's smoothing and a window's search beyond it; a crop this much wider than its points gives the
    whole frame's answer (checked in the tests)."""
    return (cfg.lk_window_px + 8) * 2 ** cfg.lk_levels


def _crops(a_px: np.ndarray, b_px: np.ndarray, pad_px: int, shape: tuple, grid_px: int
           ) -> tuple[np.ndarray, np.ndarray]:
    """Two windows of one size (Lucas-Kanade's two images must match), (x0, y0, x1, y1) each, inside a frame of
    ``shape``: one round points ``a_px``, one round ``b_px``, each widened by ``pad_px`` (as far as the frame
    allows), their corners on a grid of ``grid_px`` (the pyramid's coarsest pixel: a crop off it samples the
    coarse levels elsewhere than the whole frame does, a few tenths of a pixel apart; at the frame's right and
    bottom edges the grid may leave its last ``grid_px - 1`` pixels out)."""
    h, w = shape[:2]
    lo_a, hi_a = a_px.min(0), a_px.max(0)
    lo_b, hi_b = b_px.min(0), b_px.max(0)
    size = np.ceil(np.maximum(hi_a - lo_a, hi_b - lo_b)).astype(int) + 2 * pad_px + 2
    size = np.minimum(-(-size // grid_px) * grid_px, (w, h))
    out = []
    for lo, hi in ((lo_a, hi_a), (lo_b, hi_b)):
        x0y0 = np.clip((np.floor((lo + hi) / 2).astype(int) - size // 2) // grid_px * grid_px, 0,
                       ((w, h) - size) // grid_px * grid_px)
        out.append(np.concatenate([x0y0, x0y0 + size]))
    return out[0], out[1]


def walkers_velocity(old: np.ndarray, new: np.ndarray, H_new_from_old: np.ndarray, boxes_xyxy_px: np.ndarray,
                     dt_s: float, cfg: VelocityConfig = VelocityConfig(), on: np.ndarray | None = None,
                     off: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per box (x0, y0, x1, y1 in ``new``'s pixels), the motion against the ground of the corners in it that
    moved, from ``old`` (grey, ``dt_s`` earlier, its ground taken onto ``new``'s by ``H_new_from_old``) to
    ``new``: ((N, 2) px/s, (N,) its 1-sigma spread per axis in px/s, 0 where not measured). Masks the size of
    ``new`` (uint8): ``on``, where walkers may be (what moved): a corner elsewhere is ground, never a walker;
    ``off``, where no corner counts at all (the vehicles)."""
    n = len(boxes_xyxy_px)
    v, sigma = np.zeros((n, 2)), np.zeros(n)
    if not n or not dt_s > 0:
        return v, sigma
    h, w = new.shape[:2]
    win = (cfg.lk_window_px, cfg.lk_window_px)
    H_old_from_new = np.linalg.inv(H_new_from_old)
    flags = cv2.OPTFLOW_USE_INITIAL_FLOW
    pad = _lk_reach_px(cfg)
    for k, box in enumerate(np.asarray(boxes_xyxy_px, float)):
        bx0, by0, bx1, by1 = box_window(box, cfg.margin_px, w, h)
        if bx1 - bx0 < 3 or by1 - by0 < 3:
            continue
        q_new = cv2.goodFeaturesToTrack(new[by0:by1, bx0:bx1], cfg.max_corners, cfg.corner_quality,
                                        cfg.corner_min_distance_px)
        if q_new is None:
            continue
        q_new = (q_new.reshape(-1, 2) + (bx0, by0)).astype(np.float32)
        at = np.round(q_new).astype(int)
        if off is not None:
            q_new, at = q_new[off[at[:, 1], at[:, 0]] == 0], at[off[at[:, 1], at[:, 0]] == 0]
        walker = np.ones(len(q_new), bool) if on is None else on[at[:, 1], at[:, 0]] > 0
        if walker.sum() < cfg.min_moved:
            continue
        # searched from where the ground under each corner was: only the walkers' own motion is left to find;
        # on crops round the corners and their guesses (pyramids of the whole frames per blob cost twice the
        # rest of the detector on a busy 1280x720 video)
        guess = cv2.perspectiveTransform(q_new.reshape(-1, 1, 2).astype(np.float64), H_old_from_new).reshape(-1, 2)
        if not np.isfinite(guess).all():
            continue
        a, b = _crops(q_new, guess, pad, new.shape, 2 ** cfg.lk_levels)
        new_c, old_c = new[a[1]:a[3], a[0]:a[2]], old[b[1]:b[3], b[0]:b[2]]
        q_old, st, _ = cv2.calcOpticalFlowPyrLK(new_c, old_c, (q_new - a[:2]).astype(np.float32),
                                                (guess - b[:2]).astype(np.float32),
                                                winSize=win, maxLevel=cfg.lk_levels, flags=flags)
        q_old = q_old + b[:2]
        guess = cv2.perspectiveTransform(q_old.reshape(-1, 1, 2).astype(np.float64), H_new_from_old).reshape(-1, 2)
        q_back, st2, _ = cv2.calcOpticalFlowPyrLK(old_c, new_c, (q_old - b[:2]).astype(np.float32),
                                                  (guess - a[:2]).astype(np.float32),
                                                  winSize=win, maxLevel=cfg.lk_levels, flags=flags)
        q_back = q_back + a[:2]
        ok = (st.ravel() == 1) & (st2.ravel() == 1) & (np.hypot(*(q_back - q_new).T) < cfg.back_px)
        if (ok & walker).sum() < cfg.min_moved:
            continue
        ground = cv2.perspectiveTransform(q_old[ok].reshape(-1, 1, 2).astype(np.float64), H_new_from_old)
        motion, walker = q_new[ok] - ground.reshape(-1, 2), walker[ok]
        still = motion[(np.hypot(*motion.T) <= cfg.moved_px) & ~walker] if on is not None else \
            motion[np.hypot(*motion.T) <= cfg.moved_px]
        if len(still) >= cfg.min_still:     # what the chained fits left of the ground's motion here
            motion = motion - np.median(still, 0)
        m = motion[(np.hypot(*motion.T) > cfg.moved_px) & walker]
        if len(m) < cfg.min_moved:
            continue
        med = np.median(m, 0)
        mad = np.median(np.abs(m - med), 0)
        v[k] = med / dt_s
        sigma[k] = max(MAD_SIGMA * float(np.sqrt((mad ** 2).mean())) / np.sqrt(len(m)) / dt_s, cfg.min_sigma_px_s)
    return v, sigma
