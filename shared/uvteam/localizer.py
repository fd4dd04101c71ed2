"""The localizer step: UAV detections + UGV fixes/plans -> crowds on the ground. Pure: no I/O, no clock.

Everything here is in the localizer's east-north frame (metres); WGS84 is the message boundary's
business (:mod:`uvteam.nodes.localizer`). Per frame, :func:`localize_step` runs five phases:

1. :func:`ugv_positions` -- each UGV's ground position at the frame's capture time: interpolated
   between its fixes; a short extrapolation past the newest fix (fix latency: up to 1.5 fix intervals
   plus the latency the track has measured, at least ``fix_extrapolate_s``); when fixes are late or
   missing, its planned waypoints for at most one tracking interval after the newest fix (the paper's
   rule); else unusable.
2. :func:`pair_landmarks` -- landmark <-> blob assignment: a blob in which the detector saw a UGV's
   roof label is that UGV's (all such blobs are; its landmark is the biggest); the rest solved afresh
   at the start of each tracking interval from the label centres; inside the interval the pairing is
   kept by continuity (each UGV's previous motion-blob centre predicts where its blob is now), so a UGV
   whose label flickers keeps its blob.
   Every blob within the gate of a label is a UGV, never a crowd, unless the detector labelled another
   blob as that UGV's (it carved the UGV out of a crowd it drove into: what is left beside it is crowd).
3. :func:`landmark_pixels` -- each landmark's image point: its motion blob's centre or its label's
   (``image_coordinates``), the other when the first is missing.
4. :func:`fit_transform` -- the transform from >= 4 usable landmarks: exact (4), least squares (> 4),
   robust with named outliers (>= 5). What was known before this frame (the last transform while it
   is fresh, known at each point as well as its own landmarks' noise makes it there, else the camera's
   pose) is a prior: it tells which landmark lies when several consensus
   sets are as large, and a four-landmark fit that disagrees with it is flagged SUSPECT (its radius
   covers the disagreement). With fewer landmarks, the last good transform is held for ``hold_max_s``
   (HELD), else the camera's pose places the crowd (POSE: its ray onto the ground, less the bias learnt
   against the landmark transforms while there were some, with a radius from the attitude and height).
5. :func:`claim_blobs` and :func:`map_targets` -- every UGV whose position is known claims the blob
   whose box holds, or whose centre is near, where the transform puts it (under the pose: as far as
   the pose and the fix are worth; while the pose is fused, below, a UGV that is no landmark of the fit
   also where the pose puts it), unless its own blob, or with a landmark fit its label, was found
   there: a UGV is never a crowd, whether its label was seen there, elsewhere (a label-coloured patch
   taken for it) or not at all. Every remaining blob is mapped to the ground
   (centre and box footprint) with a 95 % radius from the propagated pixel and GNSS noise, and the
   quality flag; until the pose's bias is learnt against the fits, a fresh fit's placement is fused with
   the pose's by their covariances (:func:`fuse_with_pose`: four noisy fixes are a weak transform, and the
   pose's errors then owe nothing to them). No estimate leaves without its flag.

The pixel noise the radius propagates is what the detector declares with its detections
(:class:`FrameObservation` ``sigma_*``), unless the config overrides it. The landmarks' part (pixel
and GNSS) is scaled up by what the residuals of the fits with more than four landmarks show, averaged
over frames (:func:`learn_landmark_noise`): a label centre on real ground, a GNSS worse than it
reports or a ground that is not quite a plane widen the radius they cause, measured in flight.
"""

from __future__ import annotations

from bisect import bisect_left
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from math import hypot, inf, isfinite, nan, sqrt

import numpy as np

from .assignment import assign_greedy, assign_optimal, distance_matrix
from .blobs import Blobs, Landmarks
from .geo import LocalFrame
from .homography import Homography, fit_homography_robust, map_few, radius95_m
from .pose import PosePrior
from .vocab import IMAGE_COORDINATES, SOLVERS, FitQuality, check_choice

__all__ = [
    "UgvTrack", "FrameObservation", "LocalizerConfig", "LocalizerState", "CrowdEstimate", "StepResult",
    "UgvPosition", "Pairing", "FitOutcome", "ugv_position_at", "ugv_positions", "pair_landmarks",
    "landmark_pixels", "fit_transform", "claim_blobs", "map_targets", "fuse_with_pose", "localize_step", "ugv_track",
]
R95_PER_SIGMA = 2.4477      # the 95 % circle of an isotropic 2-D Gaussian, in sigmas


@dataclass(frozen=True, slots=True)
class UgvTrack:
    """What the localizer knows of one UGV: recent fixes (oldest first) and its planned waypoints."""

    fix_stamp_s: np.ndarray        # (k,) capture times
    fix_en_m: np.ndarray           # (k, 2) east/north in the localizer's frame
    fix_sigma_m: np.ndarray        # (k,) 1-sigma horizontal accuracy per axis
    plan_stamp_s: np.ndarray = field(default_factory=lambda: np.empty(0))   # (w,) planned times
    plan_en_m: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))  # (w, 2)
    fix_v_en_m_s: np.ndarray | None = None  # (k, 2) reported (Doppler) velocity, when the receiver gives it
    fix_latency_s: float = 0.0     # how late fixes arrive after their capture time (median, measured)

    @staticmethod
    def from_wgs84(frame: LocalFrame, fix_stamp_s, fix_lat_deg, fix_lon_deg, fix_sigma_m,
                   plan_stamp_s=(), plan_lat_deg=(), plan_lon_deg=()) -> "UgvTrack":
        fe, fn = frame.wgs84_to_ground(np.asarray(fix_lat_deg, float), np.asarray(fix_lon_deg, float))
        pe, pn = frame.wgs84_to_ground(np.asarray(plan_lat_deg, float), np.asarray(plan_lon_deg, float))
        return UgvTrack(np.asarray(fix_stamp_s, float), np.stack([fe, fn], -1).reshape(-1, 2),
                        np.asarray(fix_sigma_m, float), np.asarray(plan_stamp_s, float),
                        np.stack([pe, pn], -1).reshape(-1, 2))


def ugv_track(frame: LocalFrame, fixes: Sequence, plan=None, latency_s: float = 0.0) -> UgvTrack:
    """A UGV's track from its fixes (:class:`uvteam.messages.Fix`, oldest first) and its newest plan
    (:class:`uvteam.messages.Plan` or None). The plan starts where the UGV was when it was made: its
    position interpolated in the fixes at the plan's stamp (the newest fix when the plan is newer)."""
    st = np.array([f.stamp_s for f in fixes], float)
    e, n = frame.wgs84_to_ground(np.array([f.lat_deg for f in fixes], float), np.array([f.lon_deg for f in fixes], float))
    en = np.column_stack([e, n]).reshape(-1, 2)
    sg = np.array([f.h_acc_m for f in fixes], float)
    known_v = all(f.v_east_m_s is not None for f in fixes)
    vel = np.array([[f.v_east_m_s, f.v_north_m_s] for f in fixes], float).reshape(-1, 2) if known_v else None
    if plan is not None and plan.waypoints and len(st):
        ps = np.array([w.stamp_s for w in plan.waypoints], float)
        pe, pn = frame.wgs84_to_ground(np.array([w.lat_deg for w in plan.waypoints], float),
                                       np.array([w.lon_deg for w in plan.waypoints], float))
        start = _interp_path(st, en, plan.stamp_s)
        ps, pen = np.concatenate([[plan.stamp_s], ps]), np.vstack([start, np.column_stack([pe, pn])])
    else:
        ps, pen = np.empty(0), np.empty((0, 2))
    return UgvTrack(st, en, sg, ps, pen, vel, float(latency_s))


@dataclass(frozen=True, slots=True)
class FrameObservation:
    """One UAV frame's detections, with the 1-sigma pixel noise the detector declares for them."""

    stamp_s: float                          # capture time
    landmarks: Landmarks                    # UGV id -> roof-label centre
    blobs: Blobs                            # motion blobs; ``ugv``: the UGV whose label the detector saw in it
    sigma_color_px: float = 0.5
    sigma_ugv_blob_px: float = 1.0
    sigma_crowd_blob_px: float = 1.5
    pose: PosePrior | None = None           # the camera's pose in the localizer's frame, when reported
    px_per_m: float | None = None           # image scale at the ground (focal / height), when known
    sigma_crowd_blob_frame_px: float | None = None  # of sigma_crowd_blob_px, the part that changes from
                                                    # frame to frame (None: all of it)


@dataclass(frozen=True, slots=True)
class LocalizerConfig:
    gate_px: float = 25.0                   # the paper's epsilon
    tracking_interval_s: float = 1.0
    image_coordinates: str = "motion"       # "motion" | "color": which centre a landmark uses
    solver: str = "optimal"                 # "optimal" | "greedy"
    fix_extrapolate_s: float = 0.3          # extrapolate past the newest fix at least this long
    plan_hold_s: float | None = None        # use the plan at most this long after the newest fix
    plan_sigma_m: float = 1.0               # 1-sigma of a planned position (how well UGVs follow plans)
    hold_max_s: float = 1.0                 # hold the last transform at most this long
    held_growth_m_s: float = 2.0            # 95 % radius growth per second of hold (camera drift)
    robust_threshold_m: float = 3.0
    sigma_landmark_px: float | None = None  # None: what the detector declares (label or UGV blob, by image_coordinates)
    sigma_target_px: float | None = None    # None: what the detector declares for a crowd's blob
    min_sigma_m: float = 0.02               # floor on a fix's sigma (a reported 0 is not perfection)
    velocity_sigma_m_s: float = 0.1         # 1-sigma of a reported UGV velocity
    max_ugv_speed_m_s: float = 6.0          # bounds the drift of a UGV whose velocity is unknown
    extrapolate_fix_intervals: float = 1.5  # extrapolate up to this many of a track's fix intervals (+ its latency,
    max_fix_latency_s: float = 0.5          #   counted up to this: later fixes leave the UGV to its plan)
    prior_max_age_s: float = 1.0            # the last transform is the prior this long, then the pose is
    prior_sigma_m: float = 1.0              # how far the last transform maps a landmark off from frame to frame
    prior_growth_m_s: float = 2.0           # ... growing per second of its age (the camera moves and turns)
    suspect_sigmas: float = 4.0             # a 4-landmark fit this many sigmas from its prior is SUSPECT
    claim_radius_m: float = 2.5             # a UGV claims blobs this close to where it is (its size and trail)
    moving_m_s: float = 0.2                 # a UGV reported faster than this moves: its label alone excuses no claim
    min_vehicle_blob_m2: float = 4.0        # a UGV's own blob smaller than this (m2) is a piece of it: the rest is claimed
    pose_bias_rate: float = 0.05            # how fast the pose's bias against landmark transforms is learnt
    fuse_pose: bool = True                  # a fit's crowds fused with the pose's placement until that bias is learnt
    learn_landmark_noise: bool = True       # widen the landmarks' declared noise by what the fits' residuals show
    residual_rate: float = 0.05             # ... learnt this fast

    def __post_init__(self) -> None:
        for what, v, choices in (("image_coordinates", self.image_coordinates, IMAGE_COORDINATES),
                                 ("solver", self.solver, SOLVERS)):
            why = check_choice(what, v, choices)
            if why:
                raise ValueError(why)
        for name in ("gate_px", "tracking_interval_s", "hold_max_s", "robust_threshold_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not (self.moving_m_s >= 0 and self.min_vehicle_blob_m2 >= 0):
            raise ValueError(f"moving_m_s and min_vehicle_blob_m2 must be >= 0, got {self.moving_m_s}, "
                             f"{self.min_vehicle_blob_m2}")
        for name in ("sigma_landmark_px", "sigma_target_px"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite value >= 0 or None, got {v}")

    @property
    def plan_hold(self) -> float:
        return self.tracking_interval_s if self.plan_hold_s is None else self.plan_hold_s

    def sigmas_px(self, obs: FrameObservation) -> tuple[float, float]:
        """(landmark, target) 1-sigma pixel noise: the config's when given, else the detector's."""
        lm = obs.sigma_ugv_blob_px if self.image_coordinates == "motion" else obs.sigma_color_px
        return (lm if self.sigma_landmark_px is None else self.sigma_landmark_px,
                obs.sigma_crowd_blob_px if self.sigma_target_px is None else self.sigma_target_px)


@dataclass(frozen=True, slots=True)
class LocalizerState:
    interval_start_s: float | None = None
    blob_px_of_ugv: tuple[tuple[str, float, float], ...] = ()   # continuity: last paired blob centre
    last_fit: Homography | None = None
    last_fit_stamp_s: float = -np.inf
    last_fit_sigma_m: np.ndarray | None = None  # (n,) GNSS 1-sigma of the landmarks behind last_fit
    pose_bias_en_m: tuple[float, float] = (0.0, 0.0)  # where landmark transforms put the image centre, less the pose
    pose_bias_var_m2: float = 0.0           # the scatter of that difference (per axis)
    pose_bias_n: int = 0                    # frames it was learnt from
    landmark_chi2: float = 1.0              # the fits' residuals over those the declared noise predicts (mean)
    landmark_chi2_n: int = 0                # fits with residual freedom it was learnt from
    placed_by_pose: bool = False            # the last frame's crowds were placed by the camera's pose (POSE)


@dataclass(frozen=True, slots=True)
class CrowdEstimate:
    blob_index: int
    east_m: float
    north_m: float
    footprint_en_m: np.ndarray              # (4, 2) the blob's box corners on the ground
    radius95_m: float
    quality: FitQuality
    n_outliers: int
    area_px: float = 1.0                    # the blob's moving pixels, from the detector
    frame_radius95_m: float = 0.0           # the part of radius95_m that noise changing from frame to frame
                                            # makes (the crowd's estimates scatter by as much, :mod:`.crowds`)
    steady_radius95_m: float = 0.0          # the part of radius95_m that the steady offset the detector
                                            # declares for a crowd's blob makes (:mod:`.crowds` narrows it)
    fix_sigma_m: float = 0.0                # of the frame part, what the noise the landmarks' fixes declare
                                            # makes (a receiver's, from fix to fix): 1 sigma per axis, RMS;
                                            # 0 with no steady part (none to narrow by it, :mod:`.crowds`)
    v_en_m_s: tuple[float, float] | None = None   # the blob's walkers' velocity on the ground, when the
    sigma_v_m_s: float = 0.0                # detector measured it, and its 1-sigma spread per axis


@dataclass(frozen=True, slots=True)
class UgvPosition:
    en_m: np.ndarray                        # (2,) east/north
    sigma_m: float                          # 1-sigma per axis
    source: str                             # "fix" | "extrapolated" | "plan"
    speed_m_s: float | None = None          # the speed its receiver reports (None: not reported)


@dataclass(frozen=True, slots=True)
class Pairing:
    """Phase 2's outcome: which blob is which UGV, and which blobs are UGVs, never crowds."""

    blob_of_ugv: dict[str, int]
    is_ugv: np.ndarray                      # (N,) bool
    reference_px: dict[str, tuple[float, float]]   # the point each UGV was looked for at
    interval_start_s: float


@dataclass(frozen=True, slots=True)
class FitOutcome:
    """Phase 4's outcome: the transform to use this frame (None: none) and what it rests on."""

    fit: Homography | None
    quality: FitQuality
    sigma_m: np.ndarray                     # GNSS 1-sigma of the landmarks given to the fit
    age_s: float                            # > 0 when an earlier transform is held
    used: tuple[str, ...]
    outliers: tuple[str, ...]
    failure: str | None
    prior: "Prior | None" = None            # what was known before this frame (SUSPECT fits' radii use it)


@dataclass(frozen=True, slots=True)
class Prior:
    """What was known of the transform before this frame: the last fresh fit (``fit``), or the camera's
    pose less the bias learnt against landmark fits (``pose``, ``bias_en_m``, ``bias_var_m2``)."""

    source: str                             # "last_fit" | "pose"
    fit: Homography | None = None
    fit_sigma_m: float = 0.0                # how far the camera's motion moves it since, 1 sigma per axis
    fit_landmark_sigma_px: float = 0.0      # its landmarks' noise, pixels and (n,) GNSS m: how well it is
    fit_landmark_sigma_m: np.ndarray | None = None  # known away from them (None: as well as at them)
    pose: PosePrior | None = None
    bias_en_m: np.ndarray | None = None
    bias_var_m2: float | None = None        # None: nothing learnt yet, the pose's own error model holds

    def px_to_ground(self, xy_px) -> np.ndarray:
        if self.fit is not None:
            return self.fit.px_to_ground(xy_px)
        return self.pose.px_to_ground(xy_px) + self.bias_en_m

    def ground_to_px(self, en_m) -> np.ndarray:
        if self.fit is not None:
            return self.fit.ground_to_px(en_m)
        return self.pose.ground_to_px(np.asarray(en_m) - self.bias_en_m)

    def sigma_m(self, en_m) -> np.ndarray:
        """(N,) 1-sigma per axis of the prior at these ground points."""
        en = np.asarray(en_m, float).reshape(-1, 2)
        if self.fit is not None:
            return np.full(len(en), self.fit_sigma_m)
        model = self.pose.sigma_m(en)
        if self.bias_var_m2 is None:
            return model
        # learnt: the scatter seen at the image centre, plus what the model adds off the nadir point
        at_nadir = self.pose.sigma_m(self.pose.camera_en_m[None])[0]
        return np.sqrt(self.bias_var_m2 + np.maximum(model ** 2 - at_nadir ** 2, 0.0))


@dataclass(frozen=True, slots=True)
class StepResult:
    stamp_s: float
    quality: FitQuality
    crowds: tuple[CrowdEstimate, ...]
    landmarks_used: tuple[str, ...]
    outlier_landmarks: tuple[str, ...]
    blob_of_ugv: dict[str, int]
    position_source: dict[str, str]         # UGV id -> "fix" | "extrapolated" | "plan"
    fit_age_s: float
    failure: str | None = None
    # where this frame's crowds are placed less where the camera's pose would have placed them, as it placed the
    # last frame's (east, north m; their mean): set only in the frame in which a landmark fit takes over from the pose
    placement_shift_en_m: tuple[float, float] | None = None


def _interp_path(stamps: np.ndarray, en: np.ndarray, t: float, i: int | None = None) -> np.ndarray:
    """The path's point at ``t``: linear between the stamps around it, its first or last point beyond them
    (``i``: where ``t`` sorts into ``stamps``, when known). Two points need no array arithmetic: plain
    floats, the same bits."""
    if i is None:
        i = int(stamps.searchsorted(t))
    if i <= 0:
        return en[0].copy()
    if i >= len(stamps):
        return en[-1].copy()
    (t0, t1), ((e0, n0), (e1, n1)) = stamps[i - 1:i + 1].tolist(), en[i - 1:i + 1].tolist()
    a = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
    return np.array([e0 + a * (e1 - e0), n0 + a * (n1 - n0)])


def _median_interval_s(stamps: list[float]) -> float:
    """The median interval between consecutive stamps (0 with fewer than 2): np.median's value."""
    if len(stamps) < 2:
        return 0.0
    d = sorted([b - a for a, b in zip(stamps, stamps[1:])])
    k = len(d) // 2
    return d[k] if len(d) % 2 else (d[k - 1] + d[k]) / 2


def _extrapolate_s(track: UgvTrack, cfg: LocalizerConfig, newest: list[float] | None = None) -> float:
    """How long past its newest fix a UGV's position is extrapolated (``newest``: its newest 8 stamps)."""
    interval = _median_interval_s(track.fix_stamp_s[-8:].tolist() if newest is None else newest)
    return max(cfg.fix_extrapolate_s,
               cfg.extrapolate_fix_intervals * interval + min(track.fix_latency_s, cfg.max_fix_latency_s))


def ugv_position_at(track: UgvTrack, t_s: float, cfg: LocalizerConfig) -> UgvPosition | None:
    """A UGV's position at time t_s, or None when it is not known well enough (phase 1)."""
    fs = track.fix_stamp_s
    if len(fs):
        newest = fs[-8:].tolist()
        last = newest[-1]
        reach = _extrapolate_s(track, cfg, newest)
        if newest[0] < t_s <= last and reach >= 0:   # the common case: within the newest fixes
            i = len(fs) - len(newest) + bisect_left(newest, t_s)     # (np.searchsorted's index)
        elif float(fs[0]) - reach <= t_s <= last:
            i = int(fs.searchsorted(t_s))
        else:
            i = None
        if i is not None:
            sig = max(track.fix_sigma_m[max(i - 1, 0):i + 1].tolist())   # the worse of the two fixes around t_s
            return UgvPosition(_interp_path(fs, track.fix_en_m, t_s, i), max(sig, cfg.min_sigma_m), "fix",
                               _reported_speed(track, min(i, len(fs) - 1)))
        if 0.0 < t_s - last <= reach:
            # Extrapolate with the receiver's own velocity. Differencing two noisy fixes would amplify
            # their noise (1 m noise, 0.2 s apart: 7 m/s), so without a velocity the fix is held and
            # its sigma grows by the distance an unseen UGV could cover.
            dt = t_s - last
            sig = float(track.fix_sigma_m[-1])
            if track.fix_v_en_m_s is not None:
                (e, n), (ve, vn) = track.fix_en_m[-1].tolist(), track.fix_v_en_m_s[-1].tolist()
                p = np.array([e + ve * dt, n + vn * dt])
                sig = hypot(sig, cfg.velocity_sigma_m_s * dt)
            else:
                p = track.fix_en_m[-1].copy()
                sig = hypot(sig, cfg.max_ugv_speed_m_s * dt / 2.0)
            return UgvPosition(p, max(sig, cfg.min_sigma_m), "extrapolated", _reported_speed(track, len(fs) - 1))
        age = t_s - last
    else:
        age = np.inf
    ps = track.plan_stamp_s
    if len(ps) and age <= cfg.plan_hold and ps[0] <= t_s <= ps[-1]:
        sig = hypot(cfg.plan_sigma_m, float(track.fix_sigma_m[-1]) if len(fs) else 0.0)
        return UgvPosition(_interp_path(ps, track.plan_en_m, t_s), max(sig, cfg.min_sigma_m), "plan")
    return None


def _reported_speed(track: UgvTrack, i: int) -> float | None:
    """The speed the receiver reported with fix ``i`` (None: it reports no velocity)."""
    return None if track.fix_v_en_m_s is None else float(hypot(*track.fix_v_en_m_s[i].tolist()))


def ugv_positions(tracks: Mapping[str, UgvTrack], t_s: float, cfg: LocalizerConfig) -> dict[str, UgvPosition]:
    """Phase 1: every UGV whose position at ``t_s`` is known well enough."""
    out = {}
    for ugv, tr in tracks.items():
        pos = ugv_position_at(tr, t_s, cfg)
        if pos is not None:
            out[ugv] = pos
    return out


def _label_px(obs: FrameObservation) -> dict[str, tuple[float, float]]:
    """UGV id -> its roof label's centre (``Landmarks.as_dict``, from one ``tolist``)."""
    return dict(zip(obs.landmarks.ugv, map(tuple, obs.landmarks.xy_px.tolist())))


def pair_landmarks(state: LocalizerState, obs: FrameObservation, cfg: LocalizerConfig) -> Pairing:
    """Phase 2: blobs to UGVs (labelled blobs, then gated assignment from the labels or, inside a
    tracking interval, from each UGV's previous blob), and every blob that is a UGV."""
    t = obs.stamp_s
    blobs = obs.blobs
    xy = blobs.xy_px
    nb = len(blobs)
    new_interval = state.interval_start_s is None or t - state.interval_start_s >= cfg.tracking_interval_s \
        or t < state.interval_start_s
    label_px = _label_px(obs)
    ref: dict[str, tuple[float, float]] = dict(label_px)
    if not new_interval:   # the previous blob predicts the current one better than a flickering label
        ref.update({u: (x, y) for u, x, y in state.blob_px_of_ugv})
    # every blob the detector labelled as a UGV's is that UGV, never a crowd (a blob it split in two
    # pieces that both hold a UGV's point carves the UGV out of each: two blobs centred on it, tuning
    # seed 2 of real-alt60-lm6-two at 31.4 s, 1012 and 308 px); the UGV's landmark is the biggest
    mine = [j for j, u in enumerate(blobs.ugv) if u]
    labelled: dict[str, int] = {}
    for j in mine:
        u = blobs.ugv[j]
        if u not in labelled or blobs.area_px[j] > blobs.area_px[labelled[u]]:
            labelled[u] = j
    to_assign = sorted(u for u in ref if u not in labelled)
    if labelled:
        free = np.ones(nb, bool)
        free[mine] = False
        free = np.flatnonzero(free)
        free_xy = xy[free]
    else:
        free, free_xy = None, xy
    ref_xy = np.array([ref[u] for u in to_assign], float).reshape(-1, 2)
    solve = assign_optimal if cfg.solver == "optimal" else assign_greedy
    asg = solve(ref_xy, free_xy, cfg.gate_px)
    if free is None:
        is_ugv = asg.gated_blobs.copy()
    else:
        is_ugv = np.zeros(nb, bool)
        is_ugv[free] = asg.gated_blobs
        is_ugv[mine] = True
    # labels gate blobs too, whatever the continuity says; but not those of UGVs the detector found a
    # blob for: it carved that UGV out of whatever it drove through, so the rest is not the UGV. (At the
    # start of an interval the labels were the references: the assignment has gated their blobs.)
    unlabelled = [p for u, p in label_px.items() if u not in labelled]
    if unlabelled and nb and not new_interval:
        is_ugv |= (distance_matrix(unlabelled, xy) <= cfg.gate_px).any(0)
    blob_of_ugv = {to_assign[i]: j if free is None else int(free[j]) for i, j in asg.blob_of_landmark.items()}
    blob_of_ugv.update(labelled)
    return Pairing(blob_of_ugv, is_ugv, ref, t if new_interval else state.interval_start_s)


def landmark_pixels(obs: FrameObservation, pairing: Pairing, cfg: LocalizerConfig) -> dict[str, np.ndarray]:
    """Phase 3: each landmark's image point (motion-blob or label centre, by ``image_coordinates``)."""
    label_px = _label_px(obs)
    xy = obs.blobs.xy_px
    motion_first = cfg.image_coordinates == "motion"
    out: dict[str, np.ndarray] = {}
    for u in sorted(pairing.reference_px):
        label = label_px.get(u)
        j = pairing.blob_of_ugv.get(u)
        motion = None if j is None else xy[j]
        first, second = (motion, label) if motion_first else (label, motion)
        chosen = first if first is not None else second
        if chosen is not None:
            out[u] = np.asarray(chosen, float)
    return out


POSE_BIAS_MIN_FRAMES = 10   # the pose's bias counts as learnt after this many frames with a landmark fit


def prior_of(state: LocalizerState, obs: FrameObservation, cfg: LocalizerConfig) -> Prior | None:
    """The prior for this frame: the last fresh transform while younger than ``prior_max_age_s``, else
    the camera's pose less its learnt bias, else none."""
    age = obs.stamp_s - state.last_fit_stamp_s
    if state.last_fit is not None and 0.0 <= age <= cfg.prior_max_age_s:
        scale = landmark_noise_scale(state)
        return Prior("last_fit", fit=state.last_fit, fit_sigma_m=cfg.prior_sigma_m + cfg.prior_growth_m_s * age,
                     fit_landmark_sigma_px=cfg.sigmas_px(obs)[0] * scale,
                     fit_landmark_sigma_m=None if state.last_fit_sigma_m is None else state.last_fit_sigma_m * scale)
    if obs.pose is not None:
        learnt = state.pose_bias_n >= POSE_BIAS_MIN_FRAMES
        return Prior("pose", pose=obs.pose, bias_en_m=np.array(state.pose_bias_en_m) if learnt else np.zeros(2),
                     bias_var_m2=state.pose_bias_var_m2 if learnt else None)
    return None


def fit_transform(state: LocalizerState, t_s: float, lm_px: Mapping[str, np.ndarray],
                  positions: Mapping[str, UgvPosition], cfg: LocalizerConfig, prior: Prior | None = None) -> FitOutcome:
    """Phase 4: the transform from this frame's landmarks (the prior breaks ties between consensus sets
    and flags a four-landmark fit it disagrees with), or the last one held, or none."""
    used = tuple(u for u in sorted(lm_px) if u in positions)
    sig_m = np.array([positions[u].sigma_m for u in used])
    failure, outliers = None, ()
    if len(used) >= 4:
        px = np.array([lm_px[u] for u in used])
        en = np.array([positions[u].en_m for u in used])
        misfit = None if prior is None else _misfit(prior, px, en, sig_m)
        fit = fit_homography_robust(px, en, threshold_m=cfg.robust_threshold_m, prior_misfit=misfit)
        if fit:
            quality = fit.quality
            if len(used) == 4 and misfit is not None and misfit.max() > cfg.suspect_sigmas:
                quality = FitQuality.SUSPECT
            return FitOutcome(fit, quality, sig_m, 0.0, used, tuple(used[i] for i in fit.outliers), None, prior)
        failure = f"{fit.reason.value}: {fit.detail}"
    else:
        failure = f"too_few: {len(used)} usable landmarks"
    if state.last_fit is not None and 0.0 <= t_s - state.last_fit_stamp_s <= cfg.hold_max_s:
        return FitOutcome(state.last_fit, FitQuality.HELD, state.last_fit_sigma_m, t_s - state.last_fit_stamp_s,
                          used, outliers, failure)
    return FitOutcome(None, FitQuality.FAILED, sig_m, 0.0, used, outliers, failure, prior)


def _misfit(prior: Prior, px: np.ndarray, en: np.ndarray, sigma_m: np.ndarray) -> np.ndarray:
    """(n,) how far the prior maps each landmark's pixel from its ground position, in sigmas (the
    prior's and the landmark's GNSS together); beyond the prior's horizon: 1e6."""
    if prior.fit is None:
        miss = np.sqrt(((prior.px_to_ground(px) - en) ** 2).sum(1))
        misfit = miss / np.hypot(prior.sigma_m(en), sigma_m)
    else:   # the last transform: a handful of landmarks, in plain floats
        # known as well as its own landmarks made it there: a fit on four noisy fixes is no prior far from them
        # (real-alt60-lm6-gnss1 seed 162 at 0.9 s: two good landmarks 13 sigmas off such a fit were dropped)
        if prior.fit_landmark_sigma_m is None:
            mapped, own = map_few(prior.fit.H_ground_from_px, px.tolist()), [0.0] * len(px)
        else:    # the points come mapped with their covariances: not mapped twice
            at, cov = prior.fit.map_points_with_cov(px, 0.0, prior.fit_landmark_sigma_px, prior.fit_landmark_sigma_m)
            mapped, own = at.tolist(), np.sqrt(0.5 * (cov[:, 0, 0] + cov[:, 1, 1])).tolist()
        out = []
        for (me, mn), (e, n), s, o in zip(mapped, en.tolist(), sigma_m.tolist(), own):
            miss, scale = sqrt((me - e) * (me - e) + (mn - n) * (mn - n)), sqrt(prior.fit_sigma_m ** 2 + s * s + o * o)
            out.append(miss / scale if scale > 0 else (inf if miss > 0 else nan))
        misfit = np.array(out)
    return misfit if np.isfinite(misfit).all() else np.nan_to_num(misfit, nan=1e6)


def claim_blobs(ground_to_px, obs: FrameObservation, positions: Mapping[str, UgvPosition], pairing: Pairing,
                cfg: LocalizerConfig, pose_sigma_m: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """Phase 5a: (N,) bool, the blobs claimed by UGVs where the transform puts them (``ground_to_px``).

    "There" is within ``claim_radius_m`` (or the gate) grown by the 95 % radius of the UGV's fix error: the
    transform puts the fix where the fix is, and the vehicle's blob lies where the vehicle is. A UGV whose own
    blob was found there needs no claim: the detector carved it out of whatever it drives through, so a crowd's
    blob beside it stays a crowd; so does one whose label was found there when a landmark fit stands behind the
    labels, unless its receiver reports it moving (over ``moving_m_s``): a moving UGV's label rides on a blob of
    its own, and a label there with none is a patch of its color on the ground beside it. Any other UGV whose
    position is known (its label not seen, or seen elsewhere) claims the blobs whose box holds that point or
    whose centre is near it. A blob of its own smaller than ``min_vehicle_blob_m2`` is a piece of the vehicle (a
    label on a patch of its color beside it, or a carve that left its trail apart), so under a fit the UGV also
    claims the blobs whose centre is near its position (not those whose box merely holds it: a crowd it drives
    through keeps its blob).

    ``pose_sigma_m``: None when ``ground_to_px`` is a landmark fit (exact at its own landmarks' fixes);
    under the camera's pose, a callable of (N, 2) ground points -> (N,) its 1-sigma per axis. Then the
    reach grows by the 95 % radius of the pose's and each fix's errors together, and a label vouches
    for nothing (fewer than four, no fit checked it: a patch of the UGV's color by an unlabelled UGV
    looks the same), nor does a blob of its own smaller than ``min_vehicle_blob_m2``: the piece of
    motion the detector carved round such a patch, while the vehicle's own blob lies beside it."""
    blobs = obs.blobs
    if not positions or not len(blobs):
        return np.zeros(len(blobs), bool)
    names = sorted(positions)
    en = np.array([positions[u].en_m for u in names])
    where_px = ground_to_px(en).tolist()
    label_px = _label_px(obs)
    sigma_m = np.array([positions[u].sigma_m for u in names])     # each UGV's position, 1 sigma per axis
    if pose_sigma_m is not None:
        sigma_m = np.hypot(pose_sigma_m(en), sigma_m)
        label_px = {}
    reach_m = cfg.claim_radius_m + R95_PER_SIGMA * sigma_m
    xy = blobs.xy_px
    own = dict(pairing.blob_of_ugv)
    piece: set[str] = set()     # UGVs whose own blob is less than a vehicle's: a label's patch, or a piece of it
    if obs.px_per_m is not None:
        least_px = cfg.min_vehicle_blob_m2 * obs.px_per_m ** 2
        piece = {u for u, j in own.items() if blobs.area_px[j] < least_px}
    if pose_sigma_m is not None:    # no fit checked the labels: such a piece vouches for nothing
        own = {u: j for u, j in own.items() if u not in piece}
        piece = set()
    own_px = dict(zip(own, xy[list(own.values())].tolist()))
    claims = np.zeros(len(blobs), bool)
    box = blobs.xyxy_px
    for u, (px, py), reach in zip(names, where_px, reach_m.tolist()):
        r = cfg.gate_px if obs.px_per_m is None else max(cfg.gate_px, reach * obs.px_per_m)
        moving = (positions[u].speed_m_s or 0.0) > cfg.moving_m_s
        if not (isfinite(px) and isfinite(py)):
            continue
        excused = _near(own_px.get(u), px, py, r) or (not moving and _near(label_px.get(u), px, py, r))
        if excused and u not in piece:
            continue
        near = np.sqrt((xy[:, 0] - px) ** 2 + (xy[:, 1] - py) ** 2) <= r
        if excused:     # a piece of the vehicle: the rest of it, not a crowd whose box holds it
            claims |= near
            continue
        inside = (px >= box[:, 0]) & (px <= box[:, 2]) & (py >= box[:, 1]) & (py <= box[:, 3])
        claims |= inside | near
    return claims


def _near(q, x: float, y: float, r: float) -> bool:
    """Whether the point ``q`` (None: nowhere) lies within ``r`` of (x, y)."""
    return q is not None and hypot(q[0] - x, q[1] - y) <= r


_BOX_CORNERS = np.array([0, 1, 2, 1, 2, 3, 0, 3])   # xyxy -> (x0, y0), (x1, y0), (x1, y1), (x0, y1)


def map_targets(fit: FitOutcome, blobs: Blobs, targets: np.ndarray, sigma_landmark_px: float,
                sigma_target_px: float, cfg: LocalizerConfig, px_per_m: float | None = None,
                landmark_scale: float = 1.0, sigma_target_frame_px: float | None = None,
                pose: Prior | None = None) -> tuple[CrowdEstimate, ...]:
    """Phase 5b: the target blobs (indices) on the ground with their 95 % radii and footprints; the
    landmarks' noise (pixel and GNSS) times ``landmark_scale``. Each radius also says how much of it is
    noise that changes from frame to frame (the landmarks', and ``sigma_target_frame_px`` of the
    target's; None: all of it), and of that what the noise the fixes declare makes (where a steady part is
    declared: only that part is narrowed by it, :mod:`.crowds`). With ``pose`` (the camera's pose whose
    errors owe nothing to the landmarks: its bias not yet learnt against them), a fresh fit's placement is
    fused with the pose's where they agree (:func:`fuse_with_pose`). A point beyond the horizon of a bad
    transform is dropped: never a NaN on the map."""
    if not len(targets):
        return ()
    q = fit.quality
    steady = 0.0    # the declared steady part, in ground metres; none where the radius also covers a suspect fit
    if sigma_target_frame_px is not None and px_per_m and q != FitQuality.SUSPECT:
        steady = R95_PER_SIGMA * sqrt(max(sigma_target_px ** 2 - sigma_target_frame_px ** 2, 0.0)) / px_per_m
    centre_px = blobs.xy_px[targets]
    corners = blobs.xyxy_px[targets[:, None], _BOX_CORNERS].reshape(-1, 2)
    fix_sigma = np.zeros(len(targets))   # the fixes' part: only where a steady part is declared (below)
    if fit.quality == FitQuality.POSE:
        prior = fit.prior
        to_ground = prior.px_to_ground
        en = to_ground(centre_px)
        fp = to_ground(corners).reshape(-1, 4, 2)
        s_t = sigma_target_px / px_per_m if px_per_m else 0.0
        r95 = R95_PER_SIGMA * np.sqrt(prior.sigma_m(en) ** 2 + s_t ** 2)
        frame_r95 = r95 if sigma_target_frame_px is None else \
            np.full(len(r95), R95_PER_SIGMA * (sigma_target_frame_px / px_per_m if px_per_m else 0.0))
        n_out = 0
    else:
        h = fit.fit
        to_ground = h.px_to_ground
        s_lm, s_m = sigma_landmark_px * landmark_scale, np.asarray(fit.sigma_m, float) * landmark_scale
        all_per_frame = sigma_target_frame_px is None or sigma_target_frame_px == sigma_target_px
        fuse = pose is not None and q in _FUSED_WITH_POSE
        sigmas = (sigma_target_px,) if all_per_frame else (sigma_target_px, sigma_target_frame_px)
        en, covs = h.map_points_with_covs(centre_px, sigmas + ((0.0,) if fuse else ()), s_lm, s_m,
                                          fixes_alone=steady > 0)
        if fuse:
            en_fit = en
            at = pose.px_to_ground(centre_px)
            en, covs, floor_r95 = fuse_with_pose(en, covs, len(sigmas), at, pose.sigma_m(at))
        r95 = radius95_m(covs[0]) if not fuse else np.maximum(radius95_m(covs[0]), floor_r95)
        frame_r95 = r95 if all_per_frame else radius95_m(covs[1])
        if steady > 0:
            fix_sigma = np.sqrt(0.5 * (covs[-1][:, 0, 0] + covs[-1][:, 1, 1]))
        if fit.quality == FitQuality.HELD:
            r95 = r95 + cfg.held_growth_m_s * fit.age_s
            if all_per_frame:    # then the whole radius is the per-frame part, the held fit's growth included
                frame_r95 = r95
        if fit.quality == FitQuality.SUSPECT:   # the fit or its prior is wrong: the radius covers both
            off = np.sqrt(((en - fit.prior.px_to_ground(centre_px)) ** 2).sum(1))
            r95 = np.maximum(r95, off + R95_PER_SIGMA * fit.prior.sigma_m(en))
        fp = to_ground(corners).reshape(-1, 4, 2)
        if fuse:    # the footprint moves with its centre
            fp = fp + (en - en_fit)[:, None, :]
        n_out = int(len(h.inliers) - h.inliers.sum())
    finite = np.isfinite(np.column_stack([en, r95, fp.reshape(-1, 8)])).all(1)
    keep = range(len(targets)) if finite.all() else np.flatnonzero(finite).tolist()
    idx, e, n, r, area, rf, fx = targets.tolist(), en[:, 0].tolist(), en[:, 1].tolist(), r95.tolist(), \
        blobs.area_px[targets].tolist(), frame_r95.tolist(), fix_sigma.tolist()
    vel = _ground_velocities(to_ground, blobs, targets, centre_px, en)
    return tuple(CrowdEstimate(idx[k], e[k], n[k], fp[k], r[k], q, n_out, area[k], rf[k], min(steady, r[k]), fx[k],
                               *vel[k]) for k in keep)


_FUSED_WITH_POSE = (FitQuality.EXACT, FitQuality.LEAST_SQUARES, FitQuality.ROBUST)
POSE_FUSE_GATE = 9.21   # chi-square, 2 degrees of freedom, 99 %: a fit and a pose further apart are not fused


def fuse_with_pose(en_fit: np.ndarray, covs: list[np.ndarray], n_target: int, en_pose: np.ndarray,
                   sigma_pose_m: np.ndarray) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """A fresh fit's placements (``en_fit``, (N, 2)) fused with the camera pose's of the same pixels
    (``en_pose``, 1-sigma ``sigma_pose_m`` per axis), each weighed by its covariance, where the two agree
    within ``POSE_FUSE_GATE``. ``covs``: the fit's (N, 2, 2) covariances from
    :meth:`Homography.map_points_with_covs`, the first ``n_target`` with the target's pixel noise, then
    the transform's alone (none: the weights), then, if there, the fixes' alone. Returns the placements and
    the covariances without the transform's own: the target's pixel noise is common to both placements (the
    same pixel), so it is kept as the fit had it; the pose's part, a bias for the run, is no noise from frame
    to frame (not in the second covariance when ``n_target`` is 2).

    Four landmarks with 1 m GNSS noise at 120 m can make a transform known to 4-5 m at the crowd, the pose to
    2 m (real-alt120-lm6-gnss1 seed 160 at 1.0 s: the fit 3.6 m off, the pose, exact in that world, 0.4 m;
    tests/unit/test_montecarlo.py draws the pose off by the sigmas it declares); six exact fixes make it
    known to centimetres, and the pose moves it by as much less. Once the pose's bias is learnt against the
    fits it owes its placement to them: then it is no independent second opinion and nothing is fused."""
    C = covs[n_target]
    sigma_pose_m = np.maximum(sigma_pose_m, 1e-3)     # a pose reported exact is known to a millimetre
    S = sigma_pose_m[:, None, None] ** 2 * np.eye(2)
    y = en_pose - en_fit
    CS = C + S
    d2 = np.einsum("ni,ni->n", y, np.linalg.solve(CS, y[:, :, None])[:, :, 0])
    ok = np.isfinite(d2) & (d2 <= POSE_FUSE_GATE) & np.isfinite(en_pose).all(1)
    W_p = np.linalg.solve(CS.transpose(0, 2, 1), C.transpose(0, 2, 1)).transpose(0, 2, 1)  # C (C + S)^-1
    W_f = np.eye(2) - W_p                                                                    # S (C + S)^-1
    W_p[~ok], W_f[~ok] = 0.0, np.eye(2)
    en = en_fit + np.einsum("nij,nj->ni", W_p, np.where(ok[:, None], y, 0.0))
    lm_now = W_f @ C @ W_f.transpose(0, 2, 1)
    out = [lm_now + W_p @ S @ W_p.transpose(0, 2, 1) + (covs[0] - C)]
    out += [lm_now + (c - C) for c in covs[1:n_target]]
    out += [W_f @ c @ W_f.transpose(0, 2, 1) for c in covs[n_target + 1:]]
    # further apart, one of them is wrong: the fit's placement kept, its radius reaching the pose's too
    floor = np.where(ok | ~np.isfinite(en_pose).all(1), 0.0,
                     np.sqrt((y * y).sum(1)) + R95_PER_SIGMA * sigma_pose_m)
    return en, out, np.nan_to_num(floor)


VELOCITY_STEP_S = 0.5   # a blob's velocity is taken onto the ground as the step it makes in this long


def _ground_velocities(to_ground: Callable[[np.ndarray], np.ndarray], blobs: Blobs, targets: np.ndarray,
                       centre_px: np.ndarray, en: np.ndarray) -> list[tuple[tuple[float, float] | None, float]]:
    """Per target, its blob's walkers' velocity on the ground (m/s) and its spread (1 sigma per axis), by
    the image under ``to_ground`` (the frame's transform, the one that put its centre at ``en``) of the step
    the blob makes in ``VELOCITY_STEP_S``; (None, 0) where the detector measured none or the step leaves the
    ground."""
    out: list[tuple[tuple[float, float] | None, float]] = [(None, 0.0)] * len(targets)
    if not len(blobs.v_px_s):
        return out
    sv = blobs.sigma_v_px_s[targets]
    k = np.flatnonzero(sv > 0)
    if not len(k):
        return out
    step = centre_px[k] + blobs.v_px_s[targets[k]] * VELOCITY_STEP_S
    with np.errstate(all="ignore"):
        v = (to_ground(step) - en[k]) / VELOCITY_STEP_S
        # the spread onto the ground at the scale of that step, both axes alike (nadir-ish views)
        scale = np.hypot(*(to_ground(centre_px[k] + (1.0, 0.0)) - en[k]).T)
    s = sv[k] * scale
    for j, i in enumerate(k.tolist()):
        if np.isfinite(v[j]).all() and np.isfinite(s[j]):
            out[i] = ((float(v[j, 0]), float(v[j, 1])), float(s[j]))
    return out


def landmark_noise_scale(state: LocalizerState) -> float:
    """How much noisier the landmarks are than declared (>= 1: the declared noise is a floor)."""
    return sqrt(max(1.0, state.landmark_chi2))


def learn_landmark_noise(state: LocalizerState, fit: Homography, px: np.ndarray, en: np.ndarray,
                         sigma_landmark_px: float, sigma_m: np.ndarray, cfg: LocalizerConfig) -> LocalizerState:
    """With a fit of more than four inliers (``px``, ``en``: the landmarks given to it): its residuals
    against those the declared noise predicts (per landmark and axis, the pixel noise on the ground plus
    the fix's), chi-square over its 2 n - 8 degrees of freedom, averaged over frames (first 1/n, then
    ``residual_rate``)."""
    inl = fit.inliers
    n = int(inl.sum())
    if n <= 4:
        return state
    px, en = np.asarray(px, float)[inl], np.asarray(en, float)[inl]
    spread_en = float(np.sqrt(((en - en.mean(0)) ** 2).sum(1).mean()))
    if not spread_en > 0:
        return state
    m_per_px = spread_en / max(float(np.sqrt(((px - px.mean(0)) ** 2).sum(1).mean())), 1e-9)
    var = (sigma_landmark_px * m_per_px) ** 2 + np.broadcast_to(np.asarray(sigma_m, float), inl.shape)[inl] ** 2
    chi2 = float((fit.residual_m[inl] ** 2 / np.maximum(var, 1e-12)).sum()) / (2 * n - 8)
    if not isfinite(chi2):
        return state
    k = state.landmark_chi2_n + 1
    a = max(cfg.residual_rate, 1.0 / k)
    return replace(state, landmark_chi2=state.landmark_chi2 + a * (chi2 - state.landmark_chi2), landmark_chi2_n=k)


def learn_pose_bias(state: LocalizerState, fit: Homography, pose: PosePrior, cfg: LocalizerConfig) -> LocalizerState:
    """With a fresh landmark fit and a pose: where the fit puts the pose's nadir point, less that point,
    averaged over frames (its scatter too), so that POSE placements carry the pose's bias no more."""
    nadir_en = tuple(pose.camera_en_m.tolist())
    ((de, dn),) = map_few(fit.H_ground_from_px, map_few(pose.H_px_from_ground, [nadir_en]))
    de, dn = de - nadir_en[0], dn - nadir_en[1]
    if not (isfinite(de) and isfinite(dn)):
        return state
    n = state.pose_bias_n + 1
    a = max(cfg.pose_bias_rate, 1.0 / n)
    be, bn = state.pose_bias_en_m
    be, bn = be + a * (de - be), bn + a * (dn - bn)
    var = (1 - a) * state.pose_bias_var_m2 + a * (((de - be) * (de - be) + (dn - bn) * (dn - bn)) / 2) if n > 1 else 0.0
    return replace(state, pose_bias_en_m=(float(be), float(bn)), pose_bias_var_m2=var, pose_bias_n=n)


def localize_step(state: LocalizerState, obs: FrameObservation, tracks: Mapping[str, UgvTrack],
                  cfg: LocalizerConfig) -> tuple[LocalizerState, StepResult]:
    """One frame through the five phases (module docstring); returns the next state and the result."""
    t = obs.stamp_s
    positions = ugv_positions(tracks, t, cfg)
    pairing = pair_landmarks(state, obs, cfg)
    lm_px = landmark_pixels(obs, pairing, cfg)
    prior = prior_of(state, obs, cfg)
    fit = fit_transform(state, t, lm_px, positions, cfg, prior)
    if fit.fit is None and prior is not None and prior.source == "pose":
        fit = replace(fit, quality=FitQuality.POSE)
    crowds: tuple[CrowdEstimate, ...] = ()
    s_lm, s_tg = cfg.sigmas_px(obs)
    if (fit.fit is not None or fit.quality == FitQuality.POSE) and len(obs.blobs):
        if fit.fit is not None:
            to_px, pose_sigma = fit.fit.ground_to_px, None
        else:   # the pose's error and each UGV's fix's, independent of each other, widen the claim
            to_px, pose_sigma = prior.ground_to_px, prior.sigma_m
        is_ugv = pairing.is_ugv | claim_blobs(to_px, obs, positions, pairing, cfg, pose_sigma)
        is_ugv[list(pairing.blob_of_ugv.values())] = True
        own_pose = None    # the pose, while its bias is not learnt against the fits: independent of them
        if cfg.fuse_pose and obs.pose is not None and state.pose_bias_n < POSE_BIAS_MIN_FRAMES:
            own_pose = Prior("pose", pose=obs.pose, bias_en_m=np.zeros(2))
            # a UGV that is no landmark of a fit on a few fixes may be mapped metres off its blob by it (far
            # from its landmarks): it also claims where the pose puts it, as before the first fit
            # (real-alt120-lm6-gnss1-pose seed 187 at 1.5-2.0 s: two such UGVs' blobs reported as crowds)
            others = {u: p for u, p in positions.items() if u not in fit.used} \
                if fit.quality in _FUSED_WITH_POSE else {}
            if others:
                is_ugv |= claim_blobs(own_pose.ground_to_px, obs, others, pairing, cfg, own_pose.sigma_m)
        crowds = map_targets(fit, obs.blobs, np.flatnonzero(~is_ugv), s_lm, s_tg, cfg, obs.px_per_m,
                             landmark_noise_scale(state),
                             obs.sigma_crowd_blob_frame_px if cfg.sigma_target_px is None else None, own_pose)
    fresh = fit.fit is not None and fit.quality != FitQuality.HELD
    xy = obs.blobs.xy_px
    shift = None
    if state.placed_by_pose and crowds and fit.fit is not None and prior is not None and prior.source == "pose":
        at = prior.px_to_ground(xy[[c.blob_index for c in crowds]])
        shift = tuple(float(v) for v in (np.array([[c.east_m, c.north_m] for c in crowds]) - at).mean(0))
    new_state = replace(
        state, interval_start_s=pairing.interval_start_s,
        blob_px_of_ugv=tuple((u, *xy[j].tolist()) for u, j in sorted(pairing.blob_of_ugv.items())),
        last_fit=fit.fit if fresh else state.last_fit, last_fit_stamp_s=t if fresh else state.last_fit_stamp_s,
        last_fit_sigma_m=fit.sigma_m if fresh else state.last_fit_sigma_m,
        placed_by_pose=fit.quality == FitQuality.POSE if crowds else state.placed_by_pose)
    if fresh and obs.pose is not None and fit.quality != FitQuality.SUSPECT:
        new_state = learn_pose_bias(new_state, fit.fit, obs.pose, cfg)
    if fresh and cfg.learn_landmark_noise:
        new_state = learn_landmark_noise(new_state, fit.fit, np.array([lm_px[u] for u in fit.used]),
                                         np.array([positions[u].en_m for u in fit.used]), s_lm, fit.sigma_m, cfg)
    result = StepResult(t, fit.quality, crowds, fit.used, fit.outliers, pairing.blob_of_ugv,
                        {u: p.source for u, p in positions.items()}, fit.age_s, fit.failure, shift)
    return new_state, result
