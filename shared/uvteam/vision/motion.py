"""UAV motion detection from a moving camera (the paper's pipeline), as a state machine with no I/O.

Per frame (:meth:`MotionDetector.update`), on a copy scaled by ``process_scale`` for speed:

1. corners on the previous frame followed into the current one by pyramidal Lucas-Kanade, checked
   forward-backward; corners are not taken where the previous frame's blobs were (walkers and vehicles
   are the sharpest corners in view, and a fit that counts a walker's pixel of motion as an inlier
   leaves the ground misregistered by a pixel, which high-contrast ground such as rocks turns into
   crescents of false motion), unless too few corners are left outside them. The last fit's inliers
   are followed on from frame to frame and topped up with new ones (goodFeaturesToTrack) once fewer
   than ``TOP_UP_BELOW`` of ``max_corners`` are left; while the camera moves steadily (its last two
   motions agree), they are searched first where the last motion takes them, over one pyramid level,
   and only new corners need the forward-backward check (a followed one passed it and has been an
   inlier since); a camera that jolts gets the full search and every corner checked, and so does a
   guided search whose fit explains fewer than half the corners;
2. the camera's motion between the frames fitted robustly (RANSAC homography, or a partial affine
   transform; a fit that explains fewer than half the tracked corners is a lost registration) and the
   previous frame warped onto the current one;
3. absolute difference, threshold, restricted to pixels both frames see. The threshold is either fixed
   (``diff_threshold``: the paper's) or, with ``gradient_gain`` > 0, set per pixel by what makes static
   ground change between two registered frames: pixel noise, measured in this very difference (its
   robust sigma, times ``noise_k``, at least ``diff_floor``), plus the ground's own gradient times
   ``gradient_gain`` (a registration off by a fraction of a pixel changes a pixel by that fraction of
   its gradient, the shimmer of fine texture under a hovering camera). The gradient is measured as the
   3 x 3 neighbourhood's range (max - min: what a shift of up to a pixel can change), the smaller of
   the two frames' (where something moved, one of them shows the flat ground it left or now covers),
   and the threshold is never over ``diff_threshold``. On flat ground it drops to a few times the
   noise: walkers of little contrast (dark clothes on dark asphalt) are seen moving. With ``box_k`` > 0
   a pixel has also moved where the signed difference summed over its 3 x 3 neighbourhood passes
   ``box_k`` times that sum's own measured noise (at least ``box_floor`` a pixel) plus
   ``gradient_gain`` times the summed range: a walker of too little contrast for any one pixel to
   pass changes several pixels alike, and their sum stands out where noise of either sign cancels
   (:meth:`MotionDetector._box_moving`). It also sees still edges that flicker, as OpenCV's
   anti-aliased fill draws them (the simulator's ``lens.objects = "opencv"``; docs/results-worlds.md,
   session 25): a real lens integrates each pixel's area, as the simulator now does by default.
   With ``lag_s`` > 0 a pixel has also moved where this frame differs, by the per-pixel test, both from
   the frame ``lag_s`` ago and from the one twice as long ago (:meth:`MotionDetector._lagged_moving`):
   a slow walker of little contrast changes only a thin crescent between two frames, but its whole
   shape where it is now, and not where it was, after a few. As a pixel must pass both comparisons,
   each has its own, lower floor and noise factor (``lag_diff_floor``, ``lag_noise_k``). Until frames
   that far back are kept (a detector's first ``2 lag_s`` or so, and after a lost registration) only
   vehicles' blobs are returned (:attr:`MotionResult.warming`): a crowd's blob from the two-frame test
   alone is its walkers' crescents, and grows by a fifth or more, and may split, in the frame the
   lagged test starts, so a crowd first seen before that was known by a part of it (desert and
   real-alt120-lm6 fresh seeds 203 and 207: 3.2-3.4 m off at 0.4-0.5 s);
4. a motion history: the pixels that moved in the last ``history_s`` seconds, warped along with the
   camera so it stays registered, so that a crowd whose members move little per frame stays one blob
   (only the box around recent motion is warped: the rest is "long ago" and stays so);
5. morphology: speckle removed by opening each frame's mask (``speckle="open"``), or, for small or slow
   targets whose one-pixel crescents an opening would erase, by requiring two moving neighbours per
   pixel and opening the history instead (``"neighbours"``); a square closing of about one crowd spacing joins members
   into one blob; connected components with areas between the altitude-derived bounds (a person's footprint to
   the largest crowd) are the blobs. A blob's centre is where the pixels that moved in the history
   put it now (:func:`_centre_now`): each coordinate fitted as a straight line in the pixels' age and
   taken at age 0. Not the centroid of this frame's moving pixels alone: a walker of little contrast
   passes the threshold with a few pixels in one frame and more in the next, so one frame's pixels
   weight the crowd towards its walkers of most contrast (a crowd half over a tree's shadow was placed
   on its sunlit half, 4-5 m off); and not the history's centroid, which trails a moving crowd by half
   the history;
6. two crowds side by side (``split_px``): a blob is closed again with finer kernels, the coarsest
   first (``split_px`` times ``split_scales``); the first that leaves two or more groups each big enough
   to be a crowd on its own (``min_area_px``) splits the blob between them, every pixel going to the
   nearest such group's centre. Smaller groups (stragglers) are no crowd of their own: their pixels join
   the nearest crowd. The coarser kernels keep a small, loose crowd whole where the finest one breaks it
   into pieces each too small to count, which then joined the big crowd beside it. A blob with a
   vehicle in it is split by the finest kernel only (the walkers a vehicle cuts off are no crowd).
   The groups are sought in the history of step 3's two-frame test alone (kept beside the full one
   when ``lag_s`` > 0): what only the lagged test sees (a faint walker's whole shape) fills the gaps
   between crowds, and two crowds walking through each other were one blob between them
   (field-alt100-lm6 seed 8, 7.1 m; docs/results-worlds.md, session 33). Each component's pixels, the
   lagged test's too, still go to the nearest group. Whether two such groups are two crowds or one
   with a gap shows only over time, in how they move: :mod:`uvteam.crowds` joins them again unless
   they drift apart or together;
7. a crowd's strays (``stray_reach`` > 0): pieces of the history's moving pixels that are in no blob,
   too small for a crowd but at least ``stray_min_share`` of its least area (a walker or a few), whose
   centre lies within ``stray_reach`` merge kernels of a crowd blob's box and not within two carve radii
   of a vehicle's path, pull that (nearest) crowd's centre towards them by their share of its moving
   pixels. A crowd's walkers more than a kernel from the rest left its blob, and its centre moved with
   the dense part (tuning seed 108 of real-alt60-lm6: 1.9 m RMS from its members' centroid). Its area and
   box stay the blob's. (A piece whose joined area passed the crowd bound of step 5 while its moving pixels
   did not is neither a blob nor a stray: not handled yet.)
8. each crowd blob's velocity (``velocity_lag_s`` > 0): corners in its box on what moved in the history (off
   the carved vehicles' discs: a UGV's roof has sharper corners than any walker) followed back about that long
   on the full-resolution frames, the camera's motion taken out by the chained fits of step 2 and what those
   leave near the blob by the box's still corners (:mod:`.blob_velocity`); ``Blobs.v_px_s``. A blob's centre
   drifts as walkers go out of sight or come back; the corners on them do not.

Sizes come from the altitude and the camera (:func:`bounds_for_altitude`), as the paper bounds blobs
by size and velocity as functions of altitude. Time is passed in; nothing here reads a clock.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from math import sqrt

import cv2
import numpy as np

from ..blobs import Blobs
from .blob_velocity import VelocityConfig, box_window, walkers_velocity

MIN_VEHICLE_AREA_PX = 4.0   # a carved vehicle's blob only needs to be more than noise
AGE_UNIT_S = 0.01           # the motion history's time step
MIN_MASKED_CORNERS = 30     # fewer corners outside the blobs than this: take them anywhere
MIN_FIT_POINTS = 8          # tracked corners needed to fit the camera's motion
FORWARD_BACKWARD_PX = 1.0   # a corner tracked there and back must land within this of where it started
CORNER_BLOCK_PX = 5         # goodFeaturesToTrack's block size
LK_ITERATIONS, LK_EPSILON = 20, 0.03
AFFINE_TOLERANCE_PX = 0.05  # a homography moving no frame pixel more than this from its affine part is warped affinely
MAP_GRID_PX = 8             # a perspective warp's source computed exactly on this grid, bilinearly between
MAP_TOLERANCE_PX = 0.005    # ... when that is this close to exact everywhere (remap rounds to 1/32 px)
POOLED_LABEL_MIN_MERGE_PX = 8   # blobs joined over at least this many px are labelled on a 2x2 max-pooled mask
POOLED_LABEL_MIN_SIDE_PX = 64
NEAR_LEVELS = 1             # pyramid levels searched around where the last camera motion takes a corner
STEADY_PX = 4.0             # ... when the last two motions agree this well (a level-1 search reaches ~2 windows)
MIN_INLIER_FRACTION = 0.5   # a fit that explains fewer of the tracked corners is no camera motion
TRAIL_MAX_RADII = 1.5       # a vehicle's trail is carved at most this many carve radii behind it
TOP_UP_BELOW = 0.6          # corners followed from frame to frame are topped up below this fraction of max_corners

__all__ = ["MotionConfig", "MotionResult", "Registration", "MotionDetector", "bounds_for_altitude", "compensate"]


@dataclass(frozen=True, slots=True)
class MotionConfig:
    process_scale: float = 0.5
    max_corners: int = 300
    corner_quality: float = 0.01
    corner_min_distance_px: float = 8.0
    lk_window_px: int = 21
    lk_levels: int = 3
    model: str = "homography"          # "homography" | "affine"
    ransac_px: float = 2.0
    diff_threshold: float = 18.0       # grey levels after compensation (gradient_gain 0)
    gradient_gain: float = 0.0         # > 0: the threshold is a floor plus this times the ground's own
                                       #   3x3 range (grey levels, the smaller of both frames'), step 3;
    diff_floor: float = 8.0            #   the floor: this, or noise_k times the difference's measured
    noise_k: float = 5.0               #   noise (robust sigma), whichever is more; never over diff_threshold
    box_k: float = 0.0                 # > 0 (with gradient_gain): a pixel also moved where the signed difference's
    box_floor: float = 3.0             #   3 x 3 mean passes box_k times its own measured noise (at least
                                       #   box_floor) plus gradient_gain times the mean range (step 3)
    lag_s: float = 0.0                 # > 0: a pixel also moved where this frame differs, by step 3's per-pixel
                                       #   test, both from the frame this long ago and from the one twice as long
                                       #   ago (step 3; 0: only the last frame is compared); step 6 splits
                                       #   on the two-frame test's own history
    lag_diff_floor: float = 6.0        # the lagged test's own floor and noise_k: it ANDs two comparisons, so
    lag_noise_k: float = 4.0           #   each may pass nearer the noise (step 3)
    history_s: float = 0.4             # at most 2.5 s (the history counts in 10 ms steps, in a byte)
    compensate_max_scale: float = 0.5  # camera motion is fitted on a copy at most this scale of the input
    merge_px: int = 9                  # closing kernel (processed pixels): joins a crowd's members
    split_px: int = 0                  # finer closing kernel (processed px) that tells crowds apart; 0: none
    split_scales: tuple[float, ...] = (2.0, 1.5, 1.0)  # split_px times these, coarsest first (step 6)
    open_px: int = 3                   # opening kernel: removes speckle
    min_area_px: float = 12.0          # full-resolution pixels
    max_area_px: float = 60_000.0
    border_px: int = 6                 # ignore this margin of the warped frame
    speckle: str = "open"              # "open": open each frame's mask; "neighbours": see update()
    stray_reach: float = 0.0           # strays within this many merge_px of a crowd's box join its centre (step 7; 0: none)
    stray_min_share: float = 1.0 / 12.0  # ... if they are at least this share of min_area_px
    velocity_lag_s: float = 0.0        # > 0: each crowd blob's walkers' velocity from corners followed back about
                                       #   this long on the full-resolution frames (step 8; 0: not measured)
    velocity: VelocityConfig = VelocityConfig()

    def __post_init__(self) -> None:
        if not 0.0 < self.history_s <= 2.5:
            raise ValueError(f"history_s must be in (0, 2.5], got {self.history_s}")
        if not 0.05 <= self.compensate_max_scale <= 1.0:
            raise ValueError(f"compensate_max_scale must be in [0.05, 1], got {self.compensate_max_scale}")
        if not (self.gradient_gain >= 0.0 and self.diff_floor >= 0.0 and self.noise_k >= 0.0
                and self.box_k >= 0.0 and self.box_floor >= 0.0
                and self.lag_diff_floor >= 0.0 and self.lag_noise_k >= 0.0):
            raise ValueError(f"gradient_gain, diff_floor, noise_k, box_k, box_floor, lag_diff_floor and lag_noise_k "
                             f"must be >= 0, got {self.gradient_gain}, {self.diff_floor}, {self.noise_k}, "
                             f"{self.box_k}, {self.box_floor}, {self.lag_diff_floor}, {self.lag_noise_k}")
        if self.speckle not in ("open", "neighbours"):
            raise ValueError(f"speckle must be 'open' or 'neighbours', got {self.speckle!r}")
        if self.model not in ("homography", "affine"):
            raise ValueError(f"model must be 'homography' or 'affine', got {self.model!r}")
        if not (self.split_scales and all(f >= 1.0 for f in self.split_scales)):
            raise ValueError(f"split_scales must be factors >= 1 of split_px, got {self.split_scales}")
        if not 0.05 <= self.process_scale <= 1.0:
            raise ValueError(f"process_scale must be in [0.05, 1], got {self.process_scale}")
        if not 0.0 <= self.lag_s <= 1.0:
            raise ValueError(f"lag_s must be in [0, 1], got {self.lag_s}")
        if not 0.0 <= self.velocity_lag_s <= 2.0:
            raise ValueError(f"velocity_lag_s must be in [0, 2], got {self.velocity_lag_s}")
        if not (self.stray_reach >= 0.0 and 0.0 < self.stray_min_share <= 1.0):
            raise ValueError(f"stray_reach must be >= 0 and stray_min_share in (0, 1], got "
                             f"{self.stray_reach}, {self.stray_min_share}")


_K3 = np.ones((3, 3), np.uint8)


def _local_range(img: np.ndarray) -> np.ndarray:
    """Each pixel's 3 x 3 neighbourhood's range (max - min, grey levels, uint8): what a shift of the
    image by up to a pixel in any direction can change that pixel by (on a linear ramp twice the
    gradient's |d/dx| + |d/dy|); less than half the cost of two Sobel derivatives."""
    return cv2.morphologyEx(img, cv2.MORPH_GRADIENT, _K3)


def _robust_sigma(diff: np.ndarray, mask: np.ndarray) -> float:
    """The 1-sigma of a difference image's noise from the median of its absolute values inside ``mask``
    (robust to the few pixels that moved): 1.4826 x median, the median interpolated within its grey level."""
    hist = cv2.calcHist([diff], [0], mask, [256], [0, 256]).ravel()
    cum = np.cumsum(hist)
    if not cum[-1] > 0:
        return 0.0
    half = 0.5 * cum[-1]
    m = int(np.searchsorted(cum, half))
    below = cum[m - 1] if m > 0 else 0.0
    return float(1.4826 * max(m - 0.5 + (half - below) / hist[m], 0.0))


def bounds_for_altitude(alt_agl_m: float, focal_px: float, *, person_m: float = 0.5, spacing_m: float = 1.5,
                        crowd_max_m: float = 40.0, gap_m: float = 0.0, base: MotionConfig = MotionConfig()) -> MotionConfig:
    """Blob size bounds and the merging kernel from the altitude and the focal length (full-res px);
    ``gap_m`` > 0: the splitting kernel, the ground gap between two groups that are two crowds."""
    if not (alt_agl_m > 0 and focal_px > 0):
        raise ValueError(f"alt_agl_m and focal_px must be > 0, got {alt_agl_m}, {focal_px}")
    px_per_m = focal_px / alt_agl_m
    person_px = person_m * px_per_m
    merge = max(3, int(round(spacing_m * px_per_m * base.process_scale)) | 1)
    split = max(3, int(round(gap_m * px_per_m * base.process_scale)) | 1) if gap_m > 0 else 0
    return MotionConfig(**{**{f: getattr(base, f) for f in base.__slots__},
                           "min_area_px": max(4.0, 0.5 * person_px * person_px),
                           "max_area_px": (crowd_max_m * px_per_m) ** 2,
                           "merge_px": merge, "split_px": min(split, merge)})


@dataclass(frozen=True, slots=True)
class Registration:
    """The camera's motion between two frames (step 1-2): ``H_curr_from_prev`` in the frames' own pixels
    (None when it could not be fitted), and how well it is supported."""

    H_curr_from_prev: np.ndarray | None
    n_tracked: int             # corners that survived LK and the forward-backward check
    n_inliers: int             # of those, consistent with the camera-motion model
    residual_px: float         # RMS of the inliers' transfer error

    @staticmethod
    def failed(n_tracked: int = 0, n_inliers: int = 0) -> "Registration":
        return Registration(None, n_tracked, n_inliers, float("nan"))


@dataclass(frozen=True, slots=True)
class _Registered:
    """One frame registered ahead of its detection (:meth:`MotionDetector.register`)."""

    stamp_s: float
    prev: np.ndarray | None            # the previous frame, processed (None: this is a first frame)
    curr: np.ndarray
    dt_s: float
    registration: Registration | None  # None for a first frame
    grey: np.ndarray | None = None     # the frame in full-resolution grey, when step 8 needs it


@dataclass(frozen=True, slots=True)
class MotionResult:
    """One frame's moving blobs (full-resolution pixels), which of them are carved vehicles, and the
    camera registration they rest on (residual in processed pixels)."""

    blobs: Blobs
    carved: np.ndarray         # (N,) the carve point a vehicle's blob belongs to, else -1
    registration: Registration
    warming: bool = False      # the lagged test not yet run (step 3): vehicles' blobs only

    @staticmethod
    def empty(registration: Registration | None = None) -> "MotionResult":
        return MotionResult(Blobs.empty(), np.empty(0, int), registration or Registration.failed())

    def __len__(self) -> int:
        return len(self.blobs)

    @property
    def xy_px(self) -> np.ndarray:
        return self.blobs.xy_px

    @property
    def residual_px(self) -> float:
        return self.registration.residual_px


def _corners(prev: np.ndarray, cfg: MotionConfig, mask: np.ndarray | None, n: int) -> np.ndarray | None:
    """Up to ``n`` corners of ``prev``, where ``mask`` is non-zero unless that leaves fewer than
    ``MIN_MASKED_CORNERS`` (then anywhere)."""
    p0 = None
    if mask is not None:
        p0 = cv2.goodFeaturesToTrack(prev, n, cfg.corner_quality, cfg.corner_min_distance_px, mask=mask,
                                     blockSize=CORNER_BLOCK_PX)
        if p0 is not None and len(p0) < min(n, MIN_MASKED_CORNERS):
            p0 = None
    if p0 is None:
        p0 = cv2.goodFeaturesToTrack(prev, n, cfg.corner_quality, cfg.corner_min_distance_px, blockSize=CORNER_BLOCK_PX)
    return p0


def _top_up(prev: np.ndarray, cfg: MotionConfig, mask: np.ndarray | None,
            kept: np.ndarray | None) -> tuple[np.ndarray | None, int]:
    """The corners to follow from ``prev`` and how many of them come first from the last fit: those
    ``kept`` (already on ``prev``, off ``mask``'s zeros), topped up with new ones away from them once
    fewer than ``TOP_UP_BELOW`` of ``max_corners`` are left; all new ones when nothing is kept."""
    if kept is not None and mask is not None and len(kept):
        h, w = mask.shape
        xy = np.clip(np.round(kept.reshape(-1, 2)).astype(np.int32), 0, [w - 1, h - 1])
        kept = kept[mask[xy[:, 1], xy[:, 0]] > 0]
    if kept is None or len(kept) == 0:
        return _corners(prev, cfg, mask, cfg.max_corners), 0
    if len(kept) >= TOP_UP_BELOW * cfg.max_corners:
        return kept, len(kept)
    # new corners at least the minimum distance from the kept ones, as goodFeaturesToTrack spaces its own
    room = np.full(prev.shape, 255, np.uint8) if mask is None else mask.copy()
    r = max(1, int(round(cfg.corner_min_distance_px)))
    for x, y in np.round(kept.reshape(-1, 2)).astype(np.int32):
        cv2.circle(room, (int(x), int(y)), r, 0, -1)
    new = cv2.goodFeaturesToTrack(prev, cfg.max_corners - len(kept), cfg.corner_quality, cfg.corner_min_distance_px,
                                  mask=room, blockSize=CORNER_BLOCK_PX)
    return (kept if new is None else np.concatenate([kept, new.astype(np.float32)])), len(kept)


def _steady(last: np.ndarray | None, older: np.ndarray | None, w: int, h: int) -> np.ndarray | None:
    """``last`` when the camera moves steadily: the last two motions take the frame's corners to within
    ``STEADY_PX`` of each other (a new view, a jolt or a clip played back and forth does not)."""
    if last is None or older is None:
        return None
    c = np.float32([[[0, 0]], [[w, 0]], [[w, h]], [[0, h]]])
    d = cv2.perspectiveTransform(c, last) - cv2.perspectiveTransform(c, older)
    return last if float(np.abs(d).max()) < STEADY_PX else None


def compensate(prev: np.ndarray, curr: np.ndarray, cfg: MotionConfig, mask: np.ndarray | None = None) -> Registration:
    """Camera motion prev -> curr (steps 1-2). ``mask`` (uint8, prev's shape): corners only where it is
    non-zero, unless that leaves fewer than ``MIN_MASKED_CORNERS``."""
    return _compensate(prev, curr, cfg, _corners(prev, cfg, mask, cfg.max_corners))[0]


def _compensate(prev: np.ndarray, curr: np.ndarray, cfg: MotionConfig, p0: np.ndarray | None,
                n_followed: int = 0, guess: np.ndarray | None = None) -> tuple[Registration, np.ndarray | None]:
    """Camera motion prev -> curr from the corners ``p0`` on prev (the first ``n_followed`` of them
    followed from the frame before); and the inliers' positions in curr, the corners the next frame
    follows (None when the fit failed). ``guess``: the last camera motion; the camera moves smoothly, so
    the corners are first looked for where it would take them, over ``NEAR_LEVELS`` pyramid levels
    only, and over all of them when that loses more than half."""
    if p0 is None or len(p0) < MIN_FIT_POINTS:
        return Registration.failed(), None
    lk = dict(winSize=(cfg.lk_window_px, cfg.lk_window_px), maxLevel=cfg.lk_levels,
              criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, LK_ITERATIONS, LK_EPSILON))
    st = None
    if guess is not None and cfg.lk_levels > NEAR_LEVELS:
        pred = cv2.perspectiveTransform(p0, guess).astype(np.float32)
        p1, st, _ = cv2.calcOpticalFlowPyrLK(prev, curr, p0, pred, **{**lk, "maxLevel": NEAR_LEVELS},
                                             flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
        if st.sum() * 2 < len(p0):
            st = None
    if st is None:
        p1, st, _ = cv2.calcOpticalFlowPyrLK(prev, curr, p0, None, **lk)
    ok = st.ravel() == 1
    # the forward-backward check, for new corners only: a followed one passed it, and was an inlier since
    new = np.flatnonzero(ok[n_followed:]) + n_followed
    if len(new):
        back, st2, _ = cv2.calcOpticalFlowPyrLK(curr, prev, p1[new], None, **lk)
        fb = np.sqrt(((p0[new] - back) ** 2).sum(-1)).ravel()
        ok[new] = (st2.ravel() == 1) & (fb < FORWARD_BACKWARD_PX)
    a, b = p0[ok].reshape(-1, 2), p1[ok].reshape(-1, 2)
    if len(a) < MIN_FIT_POINTS:
        return Registration.failed(len(a)), None
    if cfg.model == "homography":
        M, inl = cv2.findHomography(a, b, cv2.RANSAC, cfg.ransac_px)
    else:
        A, inl = cv2.estimateAffinePartial2D(a, b, method=cv2.RANSAC, ransacReprojThreshold=cfg.ransac_px)
        M = None if A is None else np.vstack([A, [0.0, 0.0, 1.0]])
    if M is None or inl is None:
        return Registration.failed(len(a)), None
    inl = inl.ravel().astype(bool)
    q = cv2.perspectiveTransform(a[inl].reshape(-1, 1, 2), M).reshape(-1, 2)
    rms = float(np.sqrt(((q - b[inl]) ** 2).sum(1).mean())) if inl.any() else float("nan")
    return Registration(M, len(a), int(inl.sum()), rms), b[inl].reshape(-1, 1, 2).astype(np.float32)


def _explains(reg: Registration) -> bool:
    """Whether a fit is the camera's motion: most tracked corners agree with it (the ground fills the view)."""
    return reg.H_curr_from_prev is not None and reg.n_inliers >= MIN_INLIER_FRACTION * reg.n_tracked


def _source_maps(M: np.ndarray, w: int, h: int, scratch: dict | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """Where each pixel of a (w, h) image warped by M takes its value from (source x and y, each (h, w)
    float32), computed exactly every ``MAP_GRID_PX`` pixels and bilinearly in between: what
    ``cv2.warpPerspective`` computes per pixel (a division each, the dearest part of it), for about half
    its cost. None when the warp bends more than ``MAP_TOLERANCE_PX`` between the grid's points.
    ``scratch``: the maps are written into the arrays kept there (made on first use), as fresh arrays of
    this size each frame slowed the whole pipeline by a tenth; the maps last until the next call with it."""
    g = MAP_GRID_PX
    gw, gh = -(-w // g) + 2, -(-h // g) + 2     # one point beyond each edge: no pixel is extrapolated
    Minv = np.linalg.inv(M)

    def source(xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:   # on the grid xs x ys
        inv_z = 1.0 / np.add.outer(Minv[2, 1] * ys + Minv[2, 2], Minv[2, 0] * xs)
        return tuple(np.add.outer(Minv[r, 1] * ys + Minv[r, 2], Minv[r, 0] * xs) * inv_z for r in (0, 1))

    xs, ys = (np.arange(gw) - 1) * g + (g - 1) / 2.0, (np.arange(gh) - 1) * g + (g - 1) / 2.0
    nodes = source(xs, ys)
    # bilinear interpolation is worst midway between four points: compare it with the exact source there
    for n, exact in zip(nodes, source(xs[:-1] + g / 2.0, ys[:-1] + g / 2.0)):
        # (not <=: a source at infinity, a view through the horizon, is no map either)
        if not np.abs(0.25 * (n[:-1, :-1] + n[1:, :-1] + n[:-1, 1:] + n[1:, 1:]) - exact).max() <= MAP_TOLERANCE_PX:
            return None
    if scratch is None:
        scratch = {}
    if scratch.get("shape") != (gh * g, gw * g):
        scratch.update(shape=(gh * g, gw * g), maps=[np.empty((gh * g, gw * g), np.float32) for _ in range(2)])
    return tuple(cv2.resize(n.astype(np.float32), (gw * g, gh * g), dst=buf,
                            interpolation=cv2.INTER_LINEAR)[g:g + h, g:g + w]
                 for n, buf in zip(nodes, scratch["maps"]))


def _warper(M: np.ndarray, w: int, h: int, scratch: dict | None = None):
    """A warp by M for (w, h) images: affine (2.5x faster) when M's projective part moves no pixel of
    the frame by more than 0.05 px, as between two frames of a hovering camera; else through the
    source maps (:func:`_source_maps`, made once for every warp by M, in ``scratch``: one warper's at
    a time), or by ``cv2.warpPerspective`` when those would bend. ``roi`` (x0, y0, x1, y1): only that
    part of the warped image (the same pixels, computed alone)."""
    A = M[:2] / M[2, 2]
    corners = np.array([[0.0, 0.0], [w - 1.0, 0.0], [w - 1.0, h - 1.0], [0.0, h - 1.0]])
    hom = np.column_stack([corners, np.ones(4)])
    p = hom @ M.T
    exact = p[:, :2] / p[:, 2:3]
    affine = np.abs(exact - hom @ A.T).max() < AFFINE_TOLERANCE_PX
    maps: dict = {}

    def warp(img: np.ndarray, interp: int, border: int, roi: tuple[int, int, int, int] | None = None) -> np.ndarray:
        x0, y0, x1, y1 = roi if roi is not None else (0, 0, w, h)
        if affine:
            Ar = A.copy()
            Ar[:, 2] -= (x0, y0)
            return cv2.warpAffine(img, Ar, (x1 - x0, y1 - y0), flags=interp, borderMode=cv2.BORDER_CONSTANT,
                                  borderValue=border)
        if "source" not in maps:
            maps["source"] = _source_maps(M, w, h, scratch)
        src = maps["source"]
        if src is None:
            Mr = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]]) @ M if roi is not None else M
            return cv2.warpPerspective(img, Mr, (x1 - x0, y1 - y0), flags=interp, borderMode=cv2.BORDER_CONSTANT,
                                       borderValue=border)
        if interp == cv2.INTER_NEAREST:
            # the source rounded to whole pixels once: remap's nearest on float maps costs 3x as much
            if "nearest" not in maps:
                maps["nearest"] = (cv2.convertMaps(*src, cv2.CV_16SC2, nninterpolation=True)[0], None)
            src = maps["nearest"]
        sx, sy = src
        return cv2.remap(img, sx[y0:y1, x0:x1], None if sy is None else sy[y0:y1, x0:x1], interp,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=border)
    return warp


def _warped_box(M: np.ndarray, box: tuple[int, int, int, int], w: int, h: int) -> tuple[int, int, int, int] | None:
    """The pixels of a (w, h) image that the box (x, y, width, height) lands on under M, with a margin for
    rounding; None when it lands outside."""
    x, y, bw, bh = box
    q = cv2.perspectiveTransform(np.float32([[[x, y]], [[x + bw, y]], [[x + bw, y + bh]], [[x, y + bh]]]), M)
    lo, hi = np.floor(q.reshape(-1, 2).min(0)) - 2, np.ceil(q.reshape(-1, 2).max(0)) + 3
    x0, y0 = int(max(0, lo[0])), int(max(0, lo[1]))
    x1, y1 = int(min(w, hi[0])), int(min(h, hi[1]))
    return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None


def _d2_to_segment(gx: np.ndarray, gy: np.ndarray, a, b) -> np.ndarray:
    """Squared distance of the grid (open grids ``gx``, ``gy``) to the segment a-b (a point when a == b)."""
    ex, ey = b[0] - a[0], b[1] - a[1]
    dx, dy = gx - a[0], gy - a[1]
    ll = ex * ex + ey * ey
    if ll <= 1e-12:
        return dx * dx + dy * dy
    t = np.clip((dx * ex + dy * ey) / ll, 0.0, 1.0)
    return (dx - t * ex) ** 2 + (dy - t * ey) ** 2


def _centre_now(moved: np.ndarray, age: np.ndarray, box: tuple[int, int, int, int]) -> tuple[float, float]:
    """Where the pixels of ``moved`` (uint8 0/1, a blob's in its box) put it now: each coordinate fitted by
    least squares as a straight line in the pixel's ``age`` (the motion history's, same box) and taken at
    age 0. Every pixel that moved within the history counts, so a walker seen in some frames and not
    others weighs as much as one seen in all; the fit takes out the trail the history leaves behind a
    moving blob (its centroid lags by half the history). All pixels of one age (a blob's first frame):
    their centroid. Never outside ``box``, the box round the pixels (x, y, w, h: a few pixels fit a line
    poorly)."""
    m0 = cv2.moments(moved, binaryImage=True)
    n = m0["m00"]
    x, y = m0["m10"] / n, m0["m01"] / n
    a = age.astype(np.float32) * moved
    m1, m2 = cv2.moments(a), cv2.moments(a * a)
    a_mean = m1["m00"] / n
    a_var = m2["m00"] / n - a_mean * a_mean
    if not a_var > 1e-6:
        return x, y
    # the slope of each coordinate against age, then the line at age 0
    vx = (m1["m10"] / n - a_mean * x) / a_var
    vy = (m1["m01"] / n - a_mean * y) / a_var
    bx, by, bw, bh = box
    return min(max(x - vx * a_mean, bx), bx + bw - 1), min(max(y - vy * a_mean, by), by + bh - 1)


def _windows(boxes: np.ndarray, margin: float, w: int, h: int) -> list[tuple[int, int, int, int]]:
    """Windows (x0, y0, x1, y1; ints, x1 and y1 exclusive, inside a w x h image) round each box (x0, y0,
    x1, y1) widened by ``margin``, those that overlap joined into the box round both until none
    overlaps: every pixel within ``margin`` of a box lies in exactly one window."""
    out = [[max(int(x0 - margin), 0), max(int(y0 - margin), 0), min(int(x1 + margin) + 1, w),
            min(int(y1 + margin) + 1, h)] for x0, y0, x1, y1 in boxes]
    i = 0
    while i < len(out):
        a = out[i]
        j = next((j for j in range(len(out)) if j != i and a[0] < out[j][2] and out[j][0] < a[2]
                  and a[1] < out[j][3] and out[j][1] < a[3]), None)
        if j is None:
            i += 1
            continue
        b = out.pop(j)
        out[i - (j < i)] = [min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])]
        i = 0      # the joined window may now overlap one already passed
    return [tuple(o) for o in out]


def _pixel_scale(s: float) -> np.ndarray:
    """The homogeneous map from pixels to pixels of a copy scaled by ``s`` (pixel centres: x_s = (x + 0.5) s - 0.5)."""
    return np.array([[s, 0.0, 0.5 * s - 0.5], [0.0, s, 0.5 * s - 0.5], [0.0, 0.0, 1.0]])


def _carried_on(kept: list[tuple[float, np.ndarray, np.ndarray]], M: np.ndarray, stamp_s: float, keep_s: float
                ) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Kept frames (stamp, frame, homography onto the last frame) with each homography carried on by the camera's
    latest motion ``M`` onto this frame, those more than ``keep_s`` older than ``stamp_s`` dropped."""
    return [(t, f, M @ H) for t, f, H in kept if stamp_s - t <= keep_s + 1e-6]


def _full_res_mask(mask: np.ndarray, shape: tuple, boxes_xyxy_px: np.ndarray, s: float, margin_px: float) -> np.ndarray:
    """``mask`` (processed px, scale ``s``) at full resolution (``shape``), widened by a processed pixel, inside
    the windows step 8 seeks corners in (:func:`.blob_velocity.box_window` of each box with ``margin_px``)
    only; zero elsewhere."""
    h, w = shape[:2]
    out = np.zeros((h, w), np.uint8)
    wide = cv2.dilate(mask, _K3)
    for box in boxes_xyxy_px:
        bx0, by0, bx1, by1 = box_window(box, margin_px, w, h)
        if bx1 <= bx0 or by1 <= by0:
            continue
        px0, py0 = int(bx0 * s), int(by0 * s)
        px1, py1 = min(int(np.ceil(bx1 * s)) + 1, wide.shape[1]), min(int(np.ceil(by1 * s)) + 1, wide.shape[0])
        if px1 <= px0 or py1 <= py0:
            continue
        crop = cv2.resize(wide[py0:py1, px0:px1], None, fx=1.0 / s, fy=1.0 / s, interpolation=cv2.INTER_NEAREST)
        ox, oy = int(round(px0 / s)), int(round(py0 / s))
        ch, cw = min(crop.shape[0], h - oy), min(crop.shape[1], w - ox)
        region = out[oy:oy + ch, ox:ox + cw]
        np.maximum(region, crop[:ch, :cw], out=region)
    return out


def _close(mask: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """A closing of a blob's crop that does not join it to the crop's edge (padded with nothing moving)."""
    pad = kernel.shape[0]
    padded = cv2.copyMakeBorder(mask, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    return cv2.morphologyEx(padded, cv2.MORPH_CLOSE, kernel)[pad:-pad, pad:-pad]


class MotionDetector:
    def __init__(self, cfg: MotionConfig = MotionConfig()) -> None:
        self.cfg = cfg
        self._prev: np.ndarray | None = None
        self._prev_c: np.ndarray | None = None
        self._stamp_s: float | None = None
        self._age: np.ndarray | None = None
        self._busy: np.ndarray | None = None   # the previous frame's blobs, widened: no corners there
        self._kept: np.ndarray | None = None   # the last fit's inlier corners, on the previous frame
        self._last_H: np.ndarray | None = None  # the last camera motion, in the fit's pixels
        self._older_H: np.ndarray | None = None  # the one before
        self._age_box: tuple[int, int, int, int] | None = None   # where the motion history holds anything
        # with the lagged test: the history of the two-frame test alone, which step 6 splits on
        self._cut_age: np.ndarray | None = None
        self._cut_box: tuple[int, int, int, int] | None = None
        self._followed: dict = {}                 # carve id -> its point in the previous frame (processed px)
        self._pending: _Registered | None = None   # this frame, registered ahead of update()
        # the frames before this one, for step 3's lagged test: (stamp, processed frame, H onto this frame)
        self._older: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._since_s: float | None = None       # the frame the motion history (re)started from
        # where the warps' source maps are written: this frame's camera motion's (kept through update()),
        # and the lagged test's (one comparison at a time)
        self._maps_now: dict = {}
        self._maps_lagged: dict = {}
        # step 8: the full-resolution grey frames since velocity_lag_s and a bit, each with the camera's
        # motion from it onto the last frame (processed px)
        self._walk: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._k_open = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (cfg.open_px, cfg.open_px))
        # a square closing: it joins members up to merge_px apart, and costs the same at any size
        self._k_close = cv2.getStructuringElement(cv2.MORPH_RECT, (cfg.merge_px, cfg.merge_px))
        # the splitting kernels, coarsest first, each finer than the merging one
        sizes = sorted({max(3, min(cfg.merge_px - 2, int(round(cfg.split_px * f)) | 1)) for f in cfg.split_scales},
                       reverse=True) if cfg.split_px else []
        self._k_splits = [cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)) for k in sizes]

    def reset(self) -> None:
        self._prev = self._prev_c = self._stamp_s = self._age = self._busy = self._kept = self._age_box = None
        self._cut_age = self._cut_box = None
        self._last_H = self._older_H = None
        self._followed = {}
        self._pending = None
        self._older = []
        self._since_s = None
        self._walk = []

    def moved_near(self, xy_px: np.ndarray) -> np.ndarray | None:
        """(N,) bool: whether each full-resolution point lies on what moved in the previous frame (its
        blobs, widened by the joining kernel); None before there is a previous frame. After
        :meth:`register`, the points are this frame's and are carried back onto the previous frame by the
        camera's motion (a camera that jolts 30 px between two frames otherwise moves every label off
        its vehicle's blob)."""
        if self._busy is None:
            return None
        s = self.cfg.process_scale
        q = (np.asarray(xy_px, float).reshape(-1, 2) + 0.5) * s - 0.5
        H = self._pending_H()
        if H is not None and len(q):
            q = cv2.perspectiveTransform(q.reshape(-1, 1, 2), np.linalg.inv(H)).reshape(-1, 2)
        p = np.round(q).astype(int)
        h, w = self._busy.shape
        ok = (p[:, 0] >= 0) & (p[:, 0] < w) & (p[:, 1] >= 0) & (p[:, 1] < h)
        out = np.zeros(len(p), bool)
        out[ok] = self._busy[p[ok, 1], p[ok, 0]] > 0
        return out

    def _pending_H(self) -> np.ndarray | None:
        reg = self._pending.registration if self._pending is not None else None
        return reg.H_curr_from_prev if reg is not None else None

    def carry_forward(self, xy_px: np.ndarray) -> np.ndarray:
        """(N, 2) full-resolution points of the previous frame, where the ground under them is in this one
        (after :meth:`register`; unmoved when the camera's motion could not be fitted)."""
        xy = np.asarray(xy_px, float).reshape(-1, 2)
        H = self._pending_H()
        if H is None or not len(xy):
            return xy.copy()
        s = self.cfg.process_scale
        q = cv2.perspectiveTransform(((xy + 0.5) * s - 0.5).reshape(-1, 1, 2), H).reshape(-1, 2)
        return (q + 0.5) / s - 0.5

    def update(self, frame: np.ndarray, stamp_s: float, carve_xy_px: np.ndarray | None = None,
               carve_radius_px: float = 0.0, carve_ids: Sequence | None = None) -> MotionResult:
        """Blobs moving in ``frame``. ``carve_xy_px`` (full-resolution points, e.g. color-detected
        vehicles) split a blob that holds one of them, or has moving pixels within half ``carve_radius_px``
        of one, and is more than the carved disc: the moving pixels within ``carve_radius_px`` of the point (of its
        path, below) become a blob of their own, the rest another, so a vehicle driving through a crowd
        neither hides the crowd nor is reported as part of it; what is left is a crowd only if one group
        of it is crowd-sized on its own (not the trails of two vehicles side by side). Such a vehicle's
        blob is centred on its point, since its pixels are mixed with the crowd's. A blob that is a
        vehicle's (carved, or holding its point with no more than a vehicle's worth) says which point in
        ``MotionResult.carved``, and needs no crowd-sized area.

        ``carve_ids`` (one per point, e.g. the UGV's id) let a point be followed from frame to frame: what
        is carved is then the vehicle's path over the motion history, not only the disc where it is now,
        since a moving vehicle leaves its trail in the history (two vehicles' trails joined once made a
        crowd's area between them). The path comes from the point's motion against the ground since the
        last frame (its previous position carried over by the camera's motion), at most
        ``TRAIL_MAX_RADII`` carve radii long.

        The phases are the module docstring's steps: :meth:`_scaled` (the processed copies),
        :meth:`_register` (1-2), :meth:`_moving` (3), :meth:`_history` (4), :meth:`_components` (5),
        :meth:`_split` (6) and :meth:`_measure` (the blobs of each component)."""
        self.register(frame, stamp_s)
        p, self._pending, self._busy = self._pending, None, None
        prev, curr, dt_s, reg = p.prev, p.curr, p.dt_s, p.registration
        if reg is None:
            return MotionResult.empty()
        if reg.H_curr_from_prev is None:
            self._age[:] = 255  # lost registration: the history is no longer aligned
            self._age_box = self._cut_age = self._cut_box = None
            self._followed = {}
            self._older = []
            self._since_s = stamp_s
            self._walk = []
            return MotionResult.empty(reg)
        h, w = curr.shape
        warp = _warper(reg.H_curr_from_prev, w, h, self._maps_now)
        curr_range = _local_range(curr) if self.cfg.gradient_gain > 0 else None
        moving = self._moving(prev, curr, reg.H_curr_from_prev, warp, curr_range)
        cut, warming = None, False
        if self.cfg.lag_s > 0:
            self._keep_older(prev, reg.H_curr_from_prev, stamp_s, dt_s)
            cut, self._cut_age, self._cut_box = self._aged(moving, warp, reg.H_curr_from_prev, dt_s,
                                                           self._cut_age, self._cut_box)
            lagged = self._lagged_moving(curr, curr_range, stamp_s)
            # not yet run for want of older frames since the history began (not for a frame rate too low)
            warming = (lagged is None and self._since_s is not None
                       and stamp_s - self._since_s < 2.0 * self.cfg.lag_s)
            if lagged is not None:
                moving = cv2.bitwise_or(moving, lagged)
        recent = self._history(moving, warp, reg.H_curr_from_prev, dt_s)
        if cut is None:
            cut = recent
        joined = cv2.morphologyEx(recent, cv2.MORPH_CLOSE, self._k_close)
        # the next frame takes no corners on what moves (a corner half a kernel from a blob is on it)
        self._busy = cv2.dilate(joined, self._k_close)
        s = self.cfg.process_scale
        carve = np.empty((0, 2)) if carve_xy_px is None else (np.asarray(carve_xy_px, float).reshape(-1, 2) + 0.5) * s - 0.5
        r2 = (carve_radius_px * s) ** 2
        tails = self._tails(carve, carve_ids, reg.H_curr_from_prev, dt_s, carve_radius_px * s)
        comps = [part for x, y, comp in self._components(joined, carve)
                 for part in self._split(comp, cut[y:y + comp.shape[0], x:x + comp.shape[1]], x, y, carve, tails,
                                         r2, 1.0 / s)]
        xy, boxes, areas, carved = [], [], [], []
        for x, y, bw, bh, comp in comps:
            for row in self._measure(comp, recent[y:y + bh, x:x + bw], self._age[y:y + bh, x:x + bw], x, y, carve,
                                     tails, r2):
                xy.append(row[0])
                boxes.append(row[1])
                areas.append(row[2])
                carved.append(row[3])
        if self.cfg.stray_reach > 0 and xy:
            xy = self._with_strays(xy, boxes, areas, carved, comps, recent, carve, tails, r2)
        blobs = Blobs(np.array(xy, float).reshape(-1, 2), np.array(boxes, float).reshape(-1, 4), np.array(areas, float))
        carved_a = np.array(carved, int)
        if self.cfg.velocity_lag_s > 0:
            vehicles = np.empty((0, 2)) if carve_xy_px is None else np.asarray(carve_xy_px, float).reshape(-1, 2)
            blobs = self._with_velocity(blobs, carved_a, p.grey, reg.H_curr_from_prev, stamp_s, recent, vehicles,
                                        carve_radius_px)
        if warming:     # step 3 not yet whole: no crowd's blob (its history and velocity go on being kept)
            blobs, carved_a = blobs[carved_a >= 0], carved_a[carved_a >= 0]
        return MotionResult(blobs, carved_a, reg, warming)

    def _with_velocity(self, blobs: Blobs, carved: np.ndarray, grey: np.ndarray, M: np.ndarray, stamp_s: float,
                       recent: np.ndarray, vehicles: np.ndarray, vehicle_radius_px: float) -> Blobs:
        """Step 8: the crowd blobs' walkers' velocity (:func:`.blob_velocity.walkers_velocity`) against the
        kept frame nearest ``velocity_lag_s`` ago (none nearer than three quarters of it: not measured),
        from corners on what moved in the history (``recent``, processed px) off the vehicles' discs (a UGV
        driving past a crowd, its corners sharper than any walker's, was that crowd's velocity);
        this frame kept for the next ones."""
        lag = self.cfg.velocity_lag_s
        self._walk = _carried_on(self._walk, M, stamp_s, 1.5 * lag)
        v, sigma = np.zeros((len(blobs), 2)), np.zeros(len(blobs))
        crowds = np.flatnonzero(carved < 0)
        if self._walk and len(crowds):
            t, old, H = min(self._walk, key=lambda e: abs(stamp_s - e[0] - lag))
            if stamp_s - t >= 0.75 * lag:
                s = self.cfg.process_scale
                S = _pixel_scale(s)
                on = _full_res_mask(recent, grey.shape, blobs.xyxy_px[crowds], s, self.cfg.velocity.margin_px)
                off = None
                if len(vehicles):
                    off = np.zeros_like(on)
                    for x, y in vehicles:
                        cv2.circle(off, (int(round(x)), int(round(y))), int(np.ceil(vehicle_radius_px)), 255, -1)
                v[crowds], sigma[crowds] = walkers_velocity(old, grey, np.linalg.inv(S) @ H @ S, blobs.xyxy_px[crowds],
                                                            stamp_s - t, self.cfg.velocity, on, off)
        self._walk.append((stamp_s, grey, np.eye(3)))
        return replace(blobs, v_px_s=v, sigma_v_px_s=sigma)

    def _with_strays(self, xy: list, boxes: list, areas: list, carved: list, comps: list, recent: np.ndarray,
                     carve: np.ndarray, tails: np.ndarray, r2: float) -> list:
        """Step 7: the blobs' centres (full-resolution px), each crowd's pulled towards its strays: the
        history's moving pixels in no blob, in pieces of at least ``stray_min_share`` of a crowd's least
        area, within ``stray_reach`` merge kernels of the crowd's box and off every vehicle's path."""
        cfg = self.cfg
        s = cfg.process_scale
        inv = 1.0 / s
        crowds = [b for b, ci in enumerate(carved) if ci < 0]
        if not crowds:
            return xy
        reach = cfg.stray_reach * cfg.merge_px
        box = np.array([boxes[b] for b in crowds], float) * s    # x0, y0, x1, y1, processed px
        # labelled only round each crowd (two reaches: a piece centred within reach lies whole inside
        # unless it is longer than a reach), not over the box round all crowds: the labelling's cost
        # goes with the area labelled (docs/performance.md, session 23)
        least = cfg.min_area_px * cfg.stray_min_share * s * s    # processed px
        pull: dict[int, list[tuple[float, float, float]]] = {}
        for wx0, wy0, wx1, wy1 in _windows(box, 2 * reach, *recent.shape[::-1]):
            rest = recent[wy0:wy1, wx0:wx1].copy()
            for x, y, bw, bh, comp in comps:
                ox0, oy0, ox1, oy1 = max(x, wx0), max(y, wy0), min(x + bw, wx1), min(y + bh, wy1)
                if ox0 < ox1 and oy0 < oy1:
                    rest[oy0 - wy0:oy1 - wy0, ox0 - wx0:ox1 - wx0][comp[oy0 - y:oy1 - y, ox0 - x:ox1 - x]] = 0
            n, _, stats, centres = cv2.connectedComponentsWithStats(rest, connectivity=8)
            centres = centres + (wx0, wy0)
            for i in range(1, n):
                if stats[i, cv2.CC_STAT_AREA] < least:
                    continue
                cx, cy = centres[i]
                dx = np.maximum(np.maximum(box[:, 0] - cx, cx - box[:, 2]), 0.0)
                dy = np.maximum(np.maximum(box[:, 1] - cy, cy - box[:, 3]), 0.0)
                d = np.hypot(dx, dy)
                k = int(d.argmin())
                if d[k] >= reach:
                    continue
                if r2 > 0 and any(float(_d2_to_segment(cx, cy, carve[j], tails[j])) <= 4.0 * r2 for j in range(len(carve))):
                    continue   # a vehicle's trail, not a walker
                pull.setdefault(crowds[k], []).append((float(stats[i, cv2.CC_STAT_AREA]) * inv * inv,
                                                       (cx + 0.5) * inv - 0.5, (cy + 0.5) * inv - 0.5))
        out = list(xy)
        for b, pieces in pull.items():
            total = areas[b] + sum(a for a, _, _ in pieces)
            out[b] = [(areas[b] * xy[b][0] + sum(a * px for a, px, _ in pieces)) / total,
                      (areas[b] * xy[b][1] + sum(a * py for a, _, py in pieces)) / total]
        return out

    def register(self, frame: np.ndarray, stamp_s: float) -> Registration | None:
        """Steps 1-2 for ``frame`` ahead of :meth:`update`, which goes on from them when called with the
        same stamp (and frame); meanwhile :meth:`moved_near` takes this frame's points. None for a first
        frame (or one of another size), which has nothing to be registered with."""
        if self._pending is not None and self._pending.stamp_s == stamp_s:
            return self._pending.registration
        curr, curr_c, grey = self._scaled(frame)
        prev, self._prev = self._prev, curr
        prev_c, self._prev_c = self._prev_c, curr_c
        dt_s = stamp_s - self._stamp_s if self._stamp_s is not None else 0.0
        self._stamp_s = stamp_s
        reg = None
        if prev is None or prev.shape != curr.shape:
            self._age = np.full(curr.shape, 255, np.uint8)
            self._kept = self._age_box = self._last_H = self._older_H = self._cut_age = self._cut_box = None
            self._busy = None
            self._older = []
            self._since_s = stamp_s
            self._walk = []
        else:
            reg = self._register(prev_c, curr_c, self._busy)
        keep = None if not self.cfg.velocity_lag_s > 0 else grey.copy() if grey is frame else grey   # kept: not the caller's buffer
        self._pending = _Registered(stamp_s, prev, curr, dt_s, reg, keep)
        return reg

    def _tails(self, carve: np.ndarray, ids: Sequence | None, H: np.ndarray, dt_s: float, r_px: float) -> np.ndarray:
        """(N, 2) where each carve point's trail starts: the point itself, or, for a point followed from the
        last frame, where its motion against the ground puts it ``history_s`` ago (processed px)."""
        tails = carve.copy()
        last, self._followed = self._followed, ({} if ids is None else dict(zip(ids, carve.tolist())))
        if ids is None or dt_s <= 0.0 or not last:
            return tails
        back = self.cfg.history_s / dt_s
        for k, cid in enumerate(ids):
            if cid in last:
                q = H @ (last[cid][0], last[cid][1], 1.0)
                step = carve[k] - q[:2] / q[2]
                n = float(np.hypot(*step)) * back
                if n > 0.0:
                    tails[k] = carve[k] - step * (back * min(1.0, TRAIL_MAX_RADII * r_px / n))
        return tails

    def _scaled(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Grey at ``process_scale`` (the processed pixels), the copy the camera motion is fitted on, and the
        full-resolution grey."""
        cfg = self.cfg
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
        s = cfg.process_scale
        curr = cv2.resize(gray, None, fx=s, fy=s, interpolation=cv2.INTER_AREA) if s != 1.0 else gray
        c = min(1.0, cfg.compensate_max_scale / s)   # camera motion is global: fitted on a copy of at most that scale
        curr_c = cv2.resize(curr, None, fx=c, fy=c, interpolation=cv2.INTER_AREA) if c < 1.0 else curr
        return curr, curr_c, gray

    def _register(self, prev_c: np.ndarray, curr_c: np.ndarray, busy: np.ndarray | None) -> Registration:
        """Steps 1-2: the camera motion, fitted off the previous frame's blobs, in processed pixels."""
        free = None
        if busy is not None:
            free = cv2.bitwise_not(busy)
            if free.shape != prev_c.shape:
                free = cv2.resize(free, prev_c.shape[::-1], interpolation=cv2.INTER_NEAREST)
        p0, n_followed = _top_up(prev_c, self.cfg, free, self._kept)
        guess = _steady(self._last_H, self._older_H, *prev_c.shape[::-1])
        # a camera that jolts (gimbal jitter, a new view) gets every corner checked forward and back
        reg, self._kept = _compensate(prev_c, curr_c, self.cfg, p0, n_followed if guess is not None else 0, guess)
        if guess is not None and not _explains(reg):
            # it jolted off its steady course: the guided search found wrong places, which a fit on a
            # few of them took for the camera's motion (then every pixel "moves"): search in full
            reg, self._kept = _compensate(prev_c, curr_c, self.cfg, p0)
        if reg.H_curr_from_prev is not None and not _explains(reg):
            reg, self._kept = Registration.failed(reg.n_tracked, reg.n_inliers), None
        self._last_H, self._older_H = reg.H_curr_from_prev, self._last_H
        c = min(1.0, self.cfg.compensate_max_scale / self.cfg.process_scale)
        if reg.H_curr_from_prev is None or c >= 1.0:
            return reg
        # back to processing pixels (pixel centres: x_c = (x + 0.5) c - 0.5)
        S = _pixel_scale(c)
        return replace(reg, H_curr_from_prev=np.linalg.inv(S) @ reg.H_curr_from_prev @ S)

    def _moving(self, prev: np.ndarray, curr: np.ndarray, M: np.ndarray, warp,
                curr_range: np.ndarray | None) -> np.ndarray:
        """Step 3: the pixels that changed after compensation, where the previous frame covers this one,
        with speckle removed (``speckle``) and the frame's own edge cleared."""
        valid = self._seen_by(M, *curr.shape[::-1])
        return self._cleaned(self._changed(curr, curr_range, warp(prev, cv2.INTER_LINEAR, 0), valid))

    def _seen_by(self, M: np.ndarray, w: int, h: int) -> np.ndarray:
        """Where an earlier frame, warped onto this one by M, covers it: its corners warped, minus a border."""
        corners = cv2.perspectiveTransform(np.float32([[[0, 0]], [[w - 1, 0]], [[w - 1, h - 1]], [[0, h - 1]]]), M)
        valid = np.zeros((h, w), np.uint8)
        cv2.fillConvexPoly(valid, np.round(corners.reshape(-1, 2) * 16).astype(np.int32), 255, cv2.LINE_8, 4)
        b = 2 * self.cfg.border_px + 1
        return cv2.erode(valid, np.ones((b, b), np.uint8))

    def _changed(self, curr: np.ndarray, curr_range: np.ndarray | None, warped: np.ndarray, valid: np.ndarray,
                 lagged: bool = False) -> np.ndarray:
        """Step 3's test of ``curr`` (``curr_range``: its :func:`_local_range`, made once a frame for every
        test, None without ``gradient_gain``) against an earlier frame ``warped`` onto it, inside ``valid``
        (where the noise is measured too). ``lagged``: one of the lagged test's two comparisons, with its
        own floor and noise_k, and no box test."""
        cfg = self.cfg
        diff = cv2.absdiff(curr, warped)
        if cfg.gradient_gain > 0:
            # a registration off by a fraction of a pixel changes a pixel by that fraction of its
            # gradient: textured ground needs more change to have moved than flat ground. Where
            # something moved, one of the two frames shows the flat ground it left or covers
            base, k = (cfg.lag_diff_floor, cfg.lag_noise_k) if lagged else (cfg.diff_floor, cfg.noise_k)
            floor = max(base, k * _robust_sigma(diff, valid))
            g = cv2.min(curr_range, _local_range(warped))
            limit = cv2.min(cv2.convertScaleAbs(g, alpha=cfg.gradient_gain, beta=floor), int(cfg.diff_threshold))
            moving = cv2.compare(diff, limit, cv2.CMP_GT)
            if cfg.box_k > 0 and not lagged:
                cv2.bitwise_or(moving, self._box_moving(curr, warped, g, valid), dst=moving)
        else:
            _, moving = cv2.threshold(diff, cfg.diff_threshold, 255, cv2.THRESH_BINARY)
        return cv2.bitwise_and(moving, valid)

    def _cleaned(self, moving: np.ndarray) -> np.ndarray:
        """Step 3's mask with speckle removed (``speckle``) and the frame's own edge cleared."""
        cfg = self.cfg
        if cfg.speckle == "open":
            moving = cv2.morphologyEx(moving, cv2.MORPH_OPEN, self._k_open)
        else:
            # "neighbours": a moving pixel needs two moving neighbours; unlike an opening this keeps the
            # one-pixel crescents of a slow walker, which add up in the history and are opened there
            nb = cv2.boxFilter(moving, cv2.CV_16U, (3, 3), normalize=False)
            cv2.bitwise_and(moving, cv2.compare(nb, 3 * 255, cv2.CMP_GE), dst=moving)
        b = cfg.border_px  # the frame's own edge too: lens edge, and where a renderer or ISP extrapolates
        moving[:b] = 0
        moving[-b:] = 0
        moving[:, :b] = 0
        moving[:, -b:] = 0
        return moving

    def _keep_older(self, prev: np.ndarray, M: np.ndarray, stamp_s: float, dt_s: float) -> None:
        """The frames step 3's lagged test compares with, each with its warp onto this frame: the last
        one added (``prev``, ``dt_s`` before, ``M`` onto this frame), every older one's warp carried on by
        ``M``, those older than twice ``lag_s`` (and a frame) dropped."""
        keep_s = 2.0 * self.cfg.lag_s + max(dt_s, 0.0)
        self._older = _carried_on(self._older, M, stamp_s, keep_s)
        self._older.append((stamp_s - dt_s, prev, M))

    def _lagged_moving(self, curr: np.ndarray, curr_range: np.ndarray | None, stamp_s: float) -> np.ndarray | None:
        """Step 3's lagged test: where this frame differs both from the frame ``lag_s`` ago and from the one
        twice as long ago (the kept frames nearest those times), each by step 3's per-pixel test. A walker
        of little contrast that moves a pixel a frame changes only the crescent it steps into between two
        frames, which may pass no test; ``lag_s`` on it has stepped off its old place, so its whole shape
        differs from both frames where it is now, and where it was from one only (no ghost behind it).
        The box test is left out here: a whole shape's pixels pass alone (with it, on tuning seeds 1-3, the
        paper's 200 m scenario was 0.054 m worse and the real-imagery worlds within 0.01 m;
        docs/results-worlds.md, session 32). None until frames that far back are kept."""
        h, w = curr.shape
        lag = self.cfg.lag_s
        out, used_s = None, stamp_s
        if not self._older:
            return None
        for want_s in (lag, 2.0 * lag):
            t, old, H = min(self._older, key=lambda e: abs(stamp_s - e[0] - want_s))
            if stamp_s - t < 0.75 * want_s or t >= used_s:
                return None
            used_s = t
            warped = _warper(H, w, h, self._maps_lagged)(old, cv2.INTER_LINEAR, 0)
            valid = self._seen_by(H, w, h)
            m = self._changed(curr, curr_range, warped, valid, lagged=True)
            out = m if out is None else cv2.bitwise_and(out, m)
        return self._cleaned(out)

    def _box_moving(self, curr: np.ndarray, warped: np.ndarray, g: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """Step 3's second test: where the signed difference's 3 x 3 sum passes ``box_k`` times its own
        noise, measured in this sum (at least ``box_floor`` grey levels a pixel), plus ``gradient_gain``
        times the sum of the ground's range; never over ``diff_threshold`` a pixel. A walker of little
        contrast changes a few pixels alike, each by little more than the per-pixel noise; summed, its
        change stands out by the square root of their number (less where the noise is correlated between
        neighbours, as after JPEG: the noise is measured in the sum itself), while noise of either sign
        cancels."""
        cfg = self.cfg
        signed = cv2.subtract(curr, warped, dtype=cv2.CV_16S)
        total = cv2.convertScaleAbs(cv2.boxFilter(signed, cv2.CV_16S, (3, 3), normalize=False))
        floor = max(9.0 * cfg.box_floor, cfg.box_k * _robust_sigma(total, valid))
        g_sum = cv2.boxFilter(g, cv2.CV_16U, (3, 3), normalize=False)
        limit = cv2.min(cv2.convertScaleAbs(g_sum, alpha=cfg.gradient_gain, beta=floor),
                        int(min(255.0, 9.0 * cfg.diff_threshold)))
        return cv2.compare(total, limit, cv2.CMP_GT)

    def _history(self, moving: np.ndarray, warp, M: np.ndarray, dt_s: float) -> np.ndarray:
        """Step 4: the motion history, kept registered with the camera: each pixel's time since it last
        moved, in AGE_UNIT_S steps (uint8, saturating at "long ago"), warped along with the camera.
        Returns the pixels that moved within ``history_s``; their ages stay in ``self._age``."""
        recent, self._age, self._age_box = self._aged(moving, warp, M, dt_s, self._age, self._age_box)
        return recent

    def _aged(self, moving: np.ndarray, warp, M: np.ndarray, dt_s: float, last: np.ndarray | None,
              box: tuple[int, int, int, int] | None) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int, int]]:
        """One motion history (step 4) carried on by a frame: (the pixels that moved within ``history_s``,
        every pixel's age, the box round what moved). ``last`` (the ages before) is read only inside
        ``box``: with no box (a new history) it may be None.

        An age past ``history_s`` is kept as "long ago" (it only grows until the pixel moves again, and
        then it is 0), so the map is "long ago" but where something moved lately, and only the box
        around that is warped."""
        cfg = self.cfg
        h, w = moving.shape
        age = np.full((h, w), 255, np.uint8)
        roi = _warped_box(M, box, w, h) if box is not None and box[2] > 0 else None
        if roi is not None:
            x0, y0, x1, y1 = roi
            age[y0:y1, x0:x1] = warp(last, cv2.INTER_NEAREST, 255, roi)
        age = cv2.add(age, int(min(255, max(0, round(dt_s / AGE_UNIT_S)))))
        age = cv2.bitwise_and(age, cv2.bitwise_not(moving))   # 0 where it moves now
        _, recent = cv2.threshold(age, int(round(cfg.history_s / AGE_UNIT_S)), 255, cv2.THRESH_BINARY_INV)
        age = cv2.bitwise_or(age, cv2.bitwise_not(recent))
        box = cv2.boundingRect(recent)
        if cfg.speckle == "neighbours":
            recent = cv2.morphologyEx(recent, cv2.MORPH_OPEN, self._k_open)
        return recent, age, box

    def _components(self, joined: np.ndarray, carve: np.ndarray) -> list[tuple[int, int, np.ndarray]]:
        """Step 5: the connected components of the joined mask that can hold a blob, each as (x, y, its
        mask in its box). A component whose area (a bound on its moving pixels) is under a crowd's and
        that holds no carve point would give no blob: it is dropped before its mask is made."""
        h, w = joined.shape
        pooled = self.cfg.merge_px >= POOLED_LABEL_MIN_MERGE_PX and min(h, w) >= POOLED_LABEL_MIN_SIDE_PX
        if pooled:
            # blobs joined over >= 8 px do not need full resolution to be told apart: label a 2x2
            # max-pooled copy (4x fewer pixels), then carry each kept label back to the full mask
            h2, w2 = h // 2 * 2, w // 2 * 2
            small = cv2.resize(cv2.dilate(joined, np.ones((2, 2), np.uint8))[:h2, :w2], (w2 // 2, h2 // 2),
                               interpolation=cv2.INTER_NEAREST)
            n, labels, stats, _ = cv2.connectedComponentsWithStats(small, connectivity=8)
        else:
            n, labels, stats, _ = cv2.connectedComponentsWithStats(joined, connectivity=8)
        f = 2 if pooled else 1
        inv = 1.0 / self.cfg.process_scale
        least = self.cfg.min_area_px / (inv * inv * f * f)   # in labelled pixels
        out = []
        for i in range(1, n):
            xs, ys, bws, bhs, area = (int(v) for v in stats[i])
            x, y, bw, bh = xs * f, ys * f, bws * f, bhs * f
            if area < least and not any(x <= cx < x + bw and y <= cy < y + bh for cx, cy in carve):
                continue
            if pooled:
                crop = (labels[ys:ys + bhs, xs:xs + bws] == i).view(np.uint8)
                comp = cv2.resize(crop, (bw, bh), interpolation=cv2.INTER_NEAREST).view(bool) & (joined[y:y + bh, x:x + bw] > 0)
            else:
                comp = labels[y:y + bh, x:x + bw] == i
            out.append((x, y, comp))
        return out

    def _measure(self, comp: np.ndarray, recent: np.ndarray, age: np.ndarray, x: int, y: int,
                 carve: np.ndarray, tails: np.ndarray, r2: float) -> list[tuple[list, list, float, int]]:
        """The blobs of one (split) component at (x, y): (centre, box, area, carve point or -1) each, in
        full-resolution pixels. A component holding carve points is cut around them (see :meth:`update`)."""
        cfg = self.cfg
        inv = 1.0 / cfg.process_scale
        bh, bw = comp.shape
        m = comp & (recent > 0)       # the pixels that moved lately
        parts = [(m, cfg.min_area_px, -1)]
        centre_of: dict[int, tuple[float, float]] = {}
        inside, d2s = [], []
        if r2 > 0 and len(carve):
            # a vehicle is in the component when its point is, or when the component moved within half the
            # radius of it (the vehicle's body; its shadow and trail reach further, and so do walkers beside
            # it): a label at the edge of a crowd's blob it drives into (real-alt60-lm6 seed 148 at 6.7 s, a
            # point 0.25 px below the box) left its vehicle in the crowd's blob, which its fix then claimed
            gy, gx = np.ogrid[y:y + bh, x:x + bw]
            r = 0.5 * sqrt(r2)
            for ci, ((cx, cy), (tx, ty)) in enumerate(zip(carve.tolist(), tails.tolist())):
                held = x <= cx < x + bw and y <= cy < y + bh
                if not held and (min(cx, tx) - r > x + bw - 1 or max(cx, tx) + r < x
                                 or min(cy, ty) - r > y + bh - 1 or max(cy, ty) + r < y):
                    continue
                d2_ci = _d2_to_segment(gx, gy, carve[ci], tails[ci])
                if held or (m & (d2_ci <= r * r)).any():
                    inside.append(ci)
                    d2s.append(d2_ci)
        if inside:
            # each pixel within the radius of a vehicle's point (of its path over the history, when
            # followed) is that (nearest) vehicle's; what is left is a crowd only if one group of it is
            # crowd-sized, else the vehicles' trails
            d2 = np.stack(d2s)
            nearest = d2.argmin(0)
            near = d2.min(0) <= r2
            parts = []
            shared = len(inside) > 1
            if self._holds_crowd(m & ~near, inv):
                parts.append((m & ~near, cfg.min_area_px, -1))
                shared = True
            for k, ci in enumerate(inside):
                own = near & (nearest == k)
                parts.append((m & own, MIN_VEHICLE_AREA_PX, ci))
                if shared:   # cut out of a crowd or a neighbour: its pixels are mixed, its point is not
                    centre_of[len(parts) - 1] = (carve[ci, 0] - x, carve[ci, 1] - y)
        out = []
        for pi, (pm, min_area, ci) in enumerate(parts):
            area = float(np.count_nonzero(pm)) * inv * inv
            if not min_area <= area <= cfg.max_area_px:
                continue
            pm8 = np.ascontiguousarray(pm).view(np.uint8)
            bx, by, bw_, bh_ = cv2.boundingRect(pm8)
            if pi in centre_of:
                cx, cy = centre_of[pi]
            else:
                cx, cy = _centre_now(pm8, age, (bx, by, bw_, bh_))
            out.append(([(cx + x + 0.5) * inv - 0.5, (cy + y + 0.5) * inv - 0.5],
                        [(bx + x) * inv, (by + y) * inv, (bx + bw_ + x) * inv, (by + bh_ + y) * inv], area, ci))
        return out

    def _holds_crowd(self, rest: np.ndarray, inv: float) -> bool:
        """Whether what is left of a blob once its vehicles are carved out is a crowd: one group of it,
        joined as crowd members are, has a crowd's area on its own. Two vehicles side by side each leave
        their trail beyond the carved disc; together they can make a crowd's area, apart neither does."""
        if float(rest.sum()) * inv * inv < self.cfg.min_area_px:
            return False
        k, lab = cv2.connectedComponents(_close(rest.view(np.uint8) * np.uint8(255), self._k_close), connectivity=8)
        return bool(k > 1 and np.bincount(lab[rest], minlength=k)[1:].max() * inv * inv >= self.cfg.min_area_px)

    def _split(self, comp: np.ndarray, recent: np.ndarray, x: int, y: int, carve: np.ndarray, tails: np.ndarray,
               r2: float, inv: float) -> list[tuple[int, int, int, int, np.ndarray]]:
        """One joined component (its box at x, y) as one or more crowds' components (step 6), its groups
        sought among ``recent``'s pixels (the two-frame test's history when the lagged test is on)."""
        cfg = self.cfg
        bh, bw = comp.shape
        whole = [(x, y, bw, bh, comp)]
        m = comp & (recent > 0)
        if not self._k_splits or float(m.sum()) * inv * inv < 2 * cfg.min_area_px:
            return whole
        m8 = m.view(np.uint8) * np.uint8(255)
        gy, gx = np.ogrid[0:bh, 0:bw]
        kernels = self._k_splits
        # a vehicle is no crowd's core; with one in the blob only the finest kernel splits it: removing
        # the vehicle cuts off the walkers beyond it, which a coarser kernel would make a crowd of their own
        if r2 > 0 and len(carve):
            for (cx, cy), tail in zip(carve - (x, y), tails - (x, y)):
                if -1 <= cx <= bw and -1 <= cy <= bh:
                    m8[_d2_to_segment(gx, gy, (cx, cy), tail) <= r2] = 0
                    kernels = self._k_splits[-1:]
        pooled = kernels[-1].shape[0] >= POOLED_LABEL_MIN_MERGE_PX and min(bh, bw) >= POOLED_LABEL_MIN_SIDE_PX
        if pooled:   # as for labelling (step 5): kernels of 8 px and more close a 2x2 max-pooled copy
            h2, w2 = bh // 2 * 2, bw // 2 * 2
            m8s = cv2.resize(cv2.dilate(m8, np.ones((2, 2), np.uint8))[:h2, :w2], (w2 // 2, h2 // 2),
                             interpolation=cv2.INTER_NEAREST)
        for ker in kernels:
            if pooled:
                k2 = max(3, ker.shape[0] // 2 | 1)
                k, lab_s = cv2.connectedComponents(_close(m8s, np.ones((k2, k2), np.uint8)), connectivity=8)
                lab = np.zeros((bh, bw), np.int32)
                lab[:h2, :w2] = cv2.resize(lab_s, (w2, h2), interpolation=cv2.INTER_NEAREST)
            else:
                k, lab = cv2.connectedComponents(_close(m8, ker), connectivity=8)
            if k <= 2:
                continue
            moved = np.bincount(lab[m8 > 0], minlength=k)[1:] * inv * inv
            cores = np.flatnonzero(moved >= cfg.min_area_px) + 1
            if len(cores) >= 2:
                break
        else:
            return whole
        ys, xs = np.nonzero(m8)
        lm = lab[ys, xs]
        cent = np.array([[xs[lm == c].mean(), ys[lm == c].mean()] for c in cores])
        # each pixel of the component goes to the nearest core's centre
        cy, cx = np.nonzero(comp)
        owner = ((cx[None] - cent[:, 0, None]) ** 2 + (cy[None] - cent[:, 1, None]) ** 2).argmin(0)
        out = []
        for c in range(len(cores)):
            mine = owner == c
            py, px = cy[mine], cx[mine]
            if len(py):
                y0, y1, x0, x1 = py.min(), py.max() + 1, px.min(), px.max() + 1
                part = np.zeros((y1 - y0, x1 - x0), bool)
                part[py - y0, px - x0] = True
                out.append((x + int(x0), y + int(y0), int(x1 - x0), int(y1 - y0), part))
        return out
