"""The localizer step: UAV detections + UGV fixes/plans -> geolocated crowds. Pure: no I/O, no clock.

Per frame (:func:`localize_step`):

1. Each UGV's ground position at the frame's capture time: interpolated between its fixes; a short
   extrapolation past the newest fix (fix latency); when fixes are late or missing, its planned
   waypoints for at most one tracking interval after the newest fix (the paper's rule); else unusable.
2. Landmark <-> blob assignment: a blob in which the detector saw a UGV's roof label is that UGV's;
   the rest solved afresh at the start of each tracking interval from the color
   centres; inside the interval the pairing is kept by continuity (each UGV's previous motion-blob
   centre predicts where its blob is now), so a UGV whose color flickers keeps its blob.
   Every blob within the gate of a landmark is a UGV, never a crowd, unless the detector labelled
   another blob as that UGV's (it carved the UGV out of a crowd it drove into: what is left beside
   it is crowd); so is a blob whose box holds, or whose centre is near, the projected position of a
   UGV that was seen neither by color nor by an assigned blob in this frame.
3. The transform from >= 4 usable landmarks: exact (4), least squares (> 4), robust with named
   outliers (>= 5). With fewer, the last good transform is held for ``hold_max_s`` and flagged HELD.
4. Every remaining blob mapped to lat/lon (centre and box footprint) with a 95 % radius from the fit's
   propagated pixel and GNSS noise, and the fit's quality flag. No estimate leaves without its flag.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .assignment import assign_greedy, assign_optimal
from .geo import LocalFrame
from .homography import FitFailure, FitQuality, Homography, fit_homography_robust, radius95_m

__all__ = [
    "UgvTrack", "FrameObservation", "LocalizerConfig", "LocalizerState", "CrowdEstimate",
    "StepResult", "ugv_position_at", "localize_step",
]


@dataclass(frozen=True, slots=True)
class UgvTrack:
    """What the localizer knows of one UGV: recent fixes (oldest first) and its planned waypoints."""

    fix_stamp_s: np.ndarray        # (k,) capture times
    fix_en_m: np.ndarray           # (k, 2) east/north in the localizer's frame
    fix_sigma_m: np.ndarray        # (k,) 1-sigma horizontal accuracy per axis
    plan_stamp_s: np.ndarray = field(default_factory=lambda: np.empty(0))   # (w,) planned times
    plan_en_m: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))  # (w, 2)
    fix_v_en_m_s: np.ndarray | None = None  # (k, 2) reported (Doppler) velocity, when the receiver gives it

    @staticmethod
    def from_wgs84(frame: LocalFrame, fix_stamp_s, fix_lat_deg, fix_lon_deg, fix_sigma_m,
                   plan_stamp_s=(), plan_lat_deg=(), plan_lon_deg=()) -> "UgvTrack":
        fe, fn = frame.wgs84_to_ground(np.asarray(fix_lat_deg, float), np.asarray(fix_lon_deg, float))
        pe, pn = frame.wgs84_to_ground(np.asarray(plan_lat_deg, float), np.asarray(plan_lon_deg, float))
        return UgvTrack(np.asarray(fix_stamp_s, float), np.stack([fe, fn], -1).reshape(-1, 2),
                        np.asarray(fix_sigma_m, float), np.asarray(plan_stamp_s, float),
                        np.stack([pe, pn], -1).reshape(-1, 2))


@dataclass(frozen=True, slots=True)
class FrameObservation:
    """One UAV frame's detections."""

    stamp_s: float                          # capture time
    landmarks_px: dict[str, tuple[float, float]]  # UGV id -> color-blob centre
    blob_xy_px: np.ndarray                  # (N, 2) motion-blob centres
    blob_xyxy_px: np.ndarray                # (N, 4) motion-blob boxes
    blob_ugv: tuple[str, ...] = ()          # per blob: the UGV whose roof label the detector saw in it, or ""
    blob_area_px: np.ndarray | None = None  # (N,) moving pixels per blob (weights parts of one crowd); None: 1 each


@dataclass(frozen=True, slots=True)
class LocalizerConfig:
    frame: LocalFrame
    gate_px: float = 25.0                   # the paper's epsilon
    tracking_interval_s: float = 1.0
    image_coordinates: str = "motion"       # "motion" | "color": which centre a landmark uses
    solver: str = "optimal"                 # "optimal" | "greedy"
    fix_extrapolate_s: float = 0.3          # extrapolate past the newest fix at most this long
    plan_hold_s: float | None = None        # use the plan at most this long after the newest fix
    plan_sigma_m: float = 1.0               # 1-sigma of a planned position (how well UGVs follow plans)
    hold_max_s: float = 1.0                 # hold the last transform at most this long
    held_growth_m_s: float = 2.0            # 95 % radius growth per second of hold (camera drift)
    robust_threshold_m: float = 3.0
    sigma_landmark_px: float = 1.0
    sigma_target_px: float = 2.0
    min_sigma_m: float = 0.02               # floor on a fix's sigma (a reported 0 is not perfection)
    velocity_sigma_m_s: float = 0.1         # 1-sigma of a reported UGV velocity
    max_ugv_speed_m_s: float = 6.0          # bounds the drift of a UGV whose velocity is unknown

    def __post_init__(self) -> None:
        if self.image_coordinates not in ("motion", "color"):
            raise ValueError(f"image_coordinates must be 'motion' or 'color', got {self.image_coordinates!r}")
        if self.solver not in ("optimal", "greedy"):
            raise ValueError(f"solver must be 'optimal' or 'greedy', got {self.solver!r}")
        for name in ("gate_px", "tracking_interval_s", "hold_max_s", "robust_threshold_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")

    @property
    def plan_hold(self) -> float:
        return self.tracking_interval_s if self.plan_hold_s is None else self.plan_hold_s


@dataclass(frozen=True, slots=True)
class LocalizerState:
    interval_start_s: float | None = None
    blob_px_of_ugv: tuple[tuple[str, float, float], ...] = ()   # continuity: last paired blob centre
    last_fit: Homography | None = None
    last_fit_stamp_s: float = -np.inf
    last_fit_sigma_m: np.ndarray | None = None  # (n,) GNSS 1-sigma of the landmarks behind last_fit


@dataclass(frozen=True, slots=True)
class CrowdEstimate:
    blob_index: int
    east_m: float
    north_m: float
    lat_deg: float
    lon_deg: float
    footprint_latlon_deg: np.ndarray        # (4, 2) lat, lon of the box corners
    radius95_m: float
    quality: FitQuality
    n_outliers: int
    area_px: float = 1.0                    # the blob's moving pixels, from the detector


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


def _interp_path(stamps: np.ndarray, en: np.ndarray, t: float) -> np.ndarray:
    i = int(np.searchsorted(stamps, t))
    if i <= 0:
        return en[0].copy()
    if i >= len(stamps):
        return en[-1].copy()
    t0, t1 = stamps[i - 1], stamps[i]
    a = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
    return en[i - 1] + a * (en[i] - en[i - 1])


def ugv_position_at(track: UgvTrack, t_s: float, cfg: LocalizerConfig) -> tuple[np.ndarray, float, str] | None:
    """(east/north m, 1-sigma m, source) of a UGV at time t_s, or None when it is not known well enough."""
    fs = track.fix_stamp_s
    if len(fs):
        last = fs[-1]
        if fs[0] - cfg.fix_extrapolate_s <= t_s <= last:
            i = int(np.searchsorted(fs, t_s))
            j = max(i - 1, 0)
            sig = float(max(track.fix_sigma_m[min(i, len(fs) - 1)], track.fix_sigma_m[j]))
            return _interp_path(fs, track.fix_en_m, t_s), max(sig, cfg.min_sigma_m), "fix"
        if 0.0 < t_s - last <= cfg.fix_extrapolate_s:
            # Extrapolate with the receiver's own velocity. Differencing two noisy fixes would amplify
            # their noise (1 m noise, 0.2 s apart: 7 m/s), so without a velocity the fix is held and
            # its sigma grows by the distance an unseen UGV could cover.
            dt = t_s - last
            sig = float(track.fix_sigma_m[-1])
            if track.fix_v_en_m_s is not None:
                p = track.fix_en_m[-1] + track.fix_v_en_m_s[-1] * dt
                sig = float(np.hypot(sig, cfg.velocity_sigma_m_s * dt))
            else:
                p = track.fix_en_m[-1].copy()
                sig = float(np.hypot(sig, cfg.max_ugv_speed_m_s * dt / 2.0))
            return p, max(sig, cfg.min_sigma_m), "extrapolated"
        age = t_s - last
    else:
        age = np.inf
    ps = track.plan_stamp_s
    if len(ps) and age <= cfg.plan_hold and ps[0] <= t_s <= ps[-1]:
        sig = float(np.hypot(cfg.plan_sigma_m, track.fix_sigma_m[-1] if len(fs) else 0.0))
        return _interp_path(ps, track.plan_en_m, t_s), max(sig, cfg.min_sigma_m), "plan"
    return None


def localize_step(state: LocalizerState, obs: FrameObservation, tracks: dict[str, UgvTrack],
                  cfg: LocalizerConfig) -> tuple[LocalizerState, StepResult]:
    t = obs.stamp_s
    blobs = np.asarray(obs.blob_xy_px, float).reshape(-1, 2)
    boxes = np.asarray(obs.blob_xyxy_px, float).reshape(-1, 4)
    nb = len(blobs)
    areas = np.ones(nb) if obs.blob_area_px is None else np.asarray(obs.blob_area_px, float).reshape(-1)
    if len(areas) != nb:
        raise ValueError(f"{len(areas)} blob areas for {nb} blobs")

    # 1. UGV ground positions at the frame time
    positions: dict[str, tuple[np.ndarray, float, str]] = {}
    for ugv, tr in tracks.items():
        pos = ugv_position_at(tr, t, cfg)
        if pos is not None:
            positions[ugv] = pos

    # 2. assignment (fresh at interval start, by continuity inside it)
    new_interval = state.interval_start_s is None or t - state.interval_start_s >= cfg.tracking_interval_s \
        or t < state.interval_start_s
    prev = {u: (x, y) for u, x, y in state.blob_px_of_ugv}
    ref: dict[str, tuple[float, float]] = dict(obs.landmarks_px)
    if not new_interval:
        ref.update(prev)  # the previous blob predicts the current one better than a flickering color
    # blobs the detector already knows to be a UGV (its roof label lies in the blob) are that UGV's
    labelled = {u: j for j, u in enumerate(obs.blob_ugv[:nb]) if u}
    to_assign = sorted(u for u in ref if u not in labelled)
    free = np.array([j for j in range(nb) if j not in labelled.values()], int)
    ref_xy = np.array([ref[u] for u in to_assign], float).reshape(-1, 2)
    solve = assign_optimal if cfg.solver == "optimal" else assign_greedy
    asg = solve(ref_xy, blobs[free], cfg.gate_px)
    gated = np.zeros(nb, bool)
    gated[free] = asg.gated_blobs
    gated[list(labelled.values())] = True
    # color centres gate blobs too, whatever the continuity says; but not those of UGVs the detector
    # found a blob for: it carved that UGV out of whatever it drove through, so the rest is not the UGV
    col = [xy for u, xy in obs.landmarks_px.items() if u not in labelled]
    if col and nb:
        col = np.array(col, float)
        gated |= (np.sqrt(((col[:, None] - blobs[None]) ** 2).sum(-1)) <= cfg.gate_px).any(0)
    blob_of_ugv = {to_assign[i]: int(free[j]) for i, j in asg.blob_of_landmark.items()}
    blob_of_ugv.update(labelled)
    interval_start = t if new_interval else state.interval_start_s

    # landmark image coordinates
    lm_px: dict[str, np.ndarray] = {}
    for u in sorted(ref):
        color = obs.landmarks_px.get(u)
        motion = blobs[blob_of_ugv[u]] if u in blob_of_ugv else None
        first, second = (motion, color) if cfg.image_coordinates == "motion" else (color, motion)
        chosen = first if first is not None else second
        if chosen is not None:
            lm_px[u] = np.asarray(chosen, float)

    used = [u for u in sorted(lm_px) if u in positions]
    fit: Homography | FitFailure | None = None
    failure = None
    outliers: tuple[str, ...] = ()
    sig_m = np.array([positions[u][1] for u in used])
    if len(used) >= 4:
        px = np.array([lm_px[u] for u in used])
        en = np.array([positions[u][0] for u in used])
        fit = fit_homography_robust(px, en, threshold_m=cfg.robust_threshold_m)
        if not fit:
            failure = f"{fit.reason.value}: {fit.detail}"
            fit = None
        else:
            outliers = tuple(used[i] for i in fit.outliers)
    else:
        failure = f"too_few: {len(used)} usable landmarks"

    age = 0.0
    new_fit, new_fit_stamp, new_sig = state.last_fit, state.last_fit_stamp_s, state.last_fit_sigma_m
    if fit is not None:
        quality = fit.quality
        new_fit, new_fit_stamp, new_sig = fit, t, sig_m
    elif state.last_fit is not None and 0.0 <= t - state.last_fit_stamp_s <= cfg.hold_max_s:
        fit, sig_m = state.last_fit, state.last_fit_sigma_m
        age = t - state.last_fit_stamp_s
        quality = FitQuality.HELD
    else:
        quality = FitQuality.FAILED

    crowds: list[CrowdEstimate] = []
    if fit is not None and nb:
        # a UGV whose color was missed and that holds no assigned blob: a blob whose box holds its
        # projected position, or near it, is that UGV, never a crowd (a UGV that was seen is not looked
        # for in other blobs: the detector carves a UGV out of a crowd it drives through)
        unseen = [u for u in positions if u not in obs.landmarks_px and u not in blob_of_ugv]
        if unseen:
            ugv_px = fit.ground_to_px(np.array([positions[u][0] for u in unseen]))
            inside = ((ugv_px[:, None, 0] >= boxes[None, :, 0]) & (ugv_px[:, None, 0] <= boxes[None, :, 2])
                      & (ugv_px[:, None, 1] >= boxes[None, :, 1]) & (ugv_px[:, None, 1] <= boxes[None, :, 3]))
            near = np.sqrt(((ugv_px[:, None] - blobs[None]) ** 2).sum(-1)) <= cfg.gate_px
            gated |= (inside | near).any(0)
        targets = [j for j in range(nb) if not gated[j] and j not in blob_of_ugv.values()]
        if targets:
            en, cov = fit.map_points_with_cov(blobs[targets], cfg.sigma_target_px, cfg.sigma_landmark_px, sig_m)
            r95 = radius95_m(cov) + (cfg.held_growth_m_s * age if quality == FitQuality.HELD else 0.0)
            corners = boxes[targets][:, [0, 1, 2, 1, 2, 3, 0, 3]].reshape(-1, 2)
            pts = np.vstack([en, fit.px_to_ground(corners)])  # centres, then 4 corners each
            lat_all, lon_all = cfg.frame.ground_to_wgs84(pts[:, 0], pts[:, 1])
            nt = len(targets)
            lat, lon = lat_all[:nt], lon_all[:nt]
            fp_ll = np.stack([lat_all[nt:], lon_all[nt:]], -1).reshape(-1, 4, 2)
            n_out = int((~fit.inliers).sum())
            # a point beyond the horizon of a bad transform is dropped: never a NaN on the map
            finite = np.isfinite(en).all(1) & np.isfinite(r95) & np.isfinite(fp_ll).all((1, 2))
            for k in np.flatnonzero(finite).tolist():
                j = targets[k]
                crowds.append(CrowdEstimate(j, float(en[k, 0]), float(en[k, 1]), float(lat[k]), float(lon[k]),
                                            fp_ll[k], float(r95[k]), quality, n_out, float(areas[j])))

    new_state = replace(
        state, interval_start_s=interval_start,
        blob_px_of_ugv=tuple((u, float(blobs[j][0]), float(blobs[j][1])) for u, j in sorted(blob_of_ugv.items())),
        last_fit=new_fit, last_fit_stamp_s=new_fit_stamp, last_fit_sigma_m=new_sig)
    result = StepResult(t, quality, tuple(crowds), tuple(used), outliers, blob_of_ugv,
                        {u: p[2] for u, p in positions.items()}, age, failure)
    return new_state, result
