"""The localizer service's logic: UAV detections + UGV fixes and plans -> geolocated crowds for the team.

Per detections message (:meth:`LocalizerNode.process`): the core step
(:func:`uvteam.localizer.localize_step`), the crowd tracker and grouping
(:func:`uvteam.crowds.report_crowds`), and a Crowds message with every confirmed crowd on the
localizer's own key ``uvteam/<team>/<localizer>/crowds``. Positions stay in the localizer's east-north
frame until that message, where they become WGS84 once.

What it takes in, and refuses (counted in the status' ``rejected`` and in ``fixes_refused_*``):
- fixes and plans only from the team's UGVs, under their own keys; a fix stamped in the future beyond
  ``max_fix_skew_s`` of this host's clock, older than ``max_fix_age_s``, without a 3D fix, less accurate
  than ``max_h_acc_m``, not newer than the last, or further from the last than the UGV could have moved
  (its speed bound plus four sigmas of both fixes). So no single fix can pin a track: a run of three
  fixes that agree with each other but not with the track replaces it (a UGV that really jumped, e.g.
  after a GNSS outage);
- detections only from the configured UAV, at most ``max_blobs`` per frame (the largest), so no message
  costs more than a bounded step; the newest frame wins when the step falls behind.
A UGV whose liveliness token goes away is dropped at once; one whose fixes stop is covered by its
plan for one tracking interval, then dropped (the core's rule).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable

import numpy as np

from .. import keys
from ..bus import Bus
from ..config import LocalizerServiceConfig, VehicleConfig
from ..crowds import GroupingConfig, GroupingState, ReportedCrowd, report_crowds
from ..geo import LocalFrame
from ..localizer import FrameObservation, LocalizerConfig, LocalizerState, UgvTrack, localize_step, ugv_track
from ..messages import Crowd, Crowds, Detections, Fix, Plan
from ..pose import pose_prior
from ..sync import LatestSlot, StopFlag
from . import Counts, sender_ok

__all__ = ["LocalizerNode", "crowd_message", "refuse_fix", "localizer_config"]

log = logging.getLogger("uvteam.localizer")
FIX_HISTORY = 64
REACQUIRE_FIXES = 3          # this many refused fixes in a row that agree with each other replace the track
JUMP_SIGMAS = 4.0
JUMP_SLACK_M = 2.0


def localizer_config(lc: LocalizerServiceConfig) -> LocalizerConfig:
    """The core step's config from the service's (NaN sigmas: the detector's declared noise)."""
    return LocalizerConfig(gate_px=lc.gate_px, tracking_interval_s=lc.tracking_interval_s,
                           image_coordinates=lc.image_coordinates, solver=lc.solver, hold_max_s=lc.hold_max_s,
                           sigma_landmark_px=None if math.isnan(lc.sigma_landmark_px) else lc.sigma_landmark_px,
                           sigma_target_px=None if math.isnan(lc.sigma_target_px) else lc.sigma_target_px)


def _jumped(a: Fix, b: Fix, frame: LocalFrame, max_speed_m_s: float) -> bool:
    """Whether ``b`` lies further from ``a`` than a UGV could have moved between them."""
    ea, na = frame.wgs84_to_ground(a.lat_deg, a.lon_deg)
    eb, nb = frame.wgs84_to_ground(b.lat_deg, b.lon_deg)
    reach = max_speed_m_s * abs(b.stamp_s - a.stamp_s) + JUMP_SIGMAS * math.hypot(a.h_acc_m, b.h_acc_m) + JUMP_SLACK_M
    return math.hypot(float(eb - ea), float(nb - na)) > reach


def refuse_fix(fix: Fix, newest: Fix | None, now_s: float, lc: LocalizerServiceConfig, frame: LocalFrame,
               max_speed_m_s: float) -> str | None:
    """Why a fix is not taken into a UGV's track (None: it is). Pure."""
    if fix.stamp_s > now_s + lc.max_fix_skew_s:
        return "future"
    if fix.stamp_s < now_s - lc.max_fix_age_s:
        return "stale"
    if fix.fix_type is not None and fix.fix_type < 3:
        return "no_3d_fix"
    if fix.h_acc_m > lc.max_h_acc_m:
        return "inaccurate"
    if newest is not None:
        if fix.stamp_s <= newest.stamp_s:
            return "out_of_order"
        if _jumped(newest, fix, frame, max_speed_m_s):
            return "jump"
    return None


def crowd_message(frame: LocalFrame, r: ReportedCrowd) -> Crowd:
    """A reported crowd as the Crowds message carries it: WGS84 at the message boundary, the centre and
    the footprint's corners in one conversion."""
    c, tr = r.estimate, r.track
    pts = np.vstack([[c.east_m, c.north_m], c.footprint_en_m])
    lat, lon = frame.ground_to_wgs84(pts[:, 0], pts[:, 1])
    return Crowd(r.crowd_id, float(lat[0]), float(lon[0]), tuple(map(float, lat[1:])), tuple(map(float, lon[1:])),
                 tr.v_east_m_s, tr.v_north_m_s, c.radius95_m, c.quality.value, c.n_outliers, r.unseen_s)


class LocalizerNode:
    service = "localizer"

    def __init__(self, cfg: VehicleConfig, bus: Bus, clock: Callable[[], float] = time.time) -> None:
        self.cfg, self.bus, self.clock = cfg, bus, clock
        self.lc = cfg.localizer
        self.core = localizer_config(self.lc)
        self.grouping_cfg = GroupingConfig(confirm_hits=self.lc.confirm_hits)
        self.frame: LocalFrame | None = None
        if math.isfinite(self.lc.origin_lat_deg) and math.isfinite(self.lc.origin_lon_deg):
            self.frame = LocalFrame(self.lc.origin_lat_deg, self.lc.origin_lon_deg)
        self.fixes: dict[str, deque[Fix]] = {}
        self.refused_run: dict[str, list[Fix]] = {}
        self.latency_s: dict[str, deque[float]] = {}
        self.plans: dict[str, Plan] = {}
        self.dead: set[str] = set()
        self._lock = threading.Lock()
        self.frames = LatestSlot()
        self.state = LocalizerState()
        self.grouping = GroupingState()
        self.counts = Counts("crowds_published", "frames", "no_origin", "blobs_dropped")
        self.refusals = Counts()
        self.step_us: deque[float] = deque(maxlen=1000)
        self.last_quality = "none"
        self.out_key = keys.key(cfg.team, cfg.id, "crowds")

    # --- bus side (zenoh's threads, or the publisher's on the in-memory bus) ----------------------
    def start(self) -> None:
        team = self.cfg.team
        self.bus.subscribe(keys.all_vehicles(team, "fix"), Fix, self.on_fix)
        self.bus.subscribe(keys.all_vehicles(team, "plan"), Plan, self.on_plan)
        self.bus.subscribe(keys.key(team, self.lc.uav, "detections"), Detections, self.on_detections)
        self.bus.watch_alive(keys.alive_all(team), self.on_alive)

    def is_ugv(self, vehicle: str) -> bool:
        return vehicle in self.lc.ugvs if self.lc.ugvs else vehicle not in (self.lc.uav, self.cfg.id)

    def on_fix(self, key: str, fix: Fix) -> None:
        if not self.is_ugv(fix.vehicle):
            return
        if not sender_ok(key, fix.vehicle):
            self.bus.reject(key, f"a fix for {fix.vehicle} under another vehicle's key")
            return
        now = self.clock()
        with self._lock:
            if self.frame is None:
                self.frame = LocalFrame(fix.lat_deg, fix.lon_deg)
                log.info("local frame origin from %s's first fix: %.7f, %.7f", fix.vehicle, fix.lat_deg, fix.lon_deg)
            d = self.fixes.setdefault(fix.vehicle, deque(maxlen=FIX_HISTORY))
            why = refuse_fix(fix, d[-1] if d else None, now, self.lc, self.frame, self.core.max_ugv_speed_m_s)
            if why == "jump" and self._reacquire(fix, d):
                why = None
            if why is not None:
                self.refusals.add(why)
                if why not in ("out_of_order",):
                    self.bus.reject(key, f"fix refused: {why}")
                return
            self.refused_run.pop(fix.vehicle, None)
            d.append(fix)
            self.latency_s.setdefault(fix.vehicle, deque(maxlen=32)).append(max(now - fix.stamp_s, 0.0))
            self.dead.discard(fix.vehicle)

    def _reacquire(self, fix: Fix, track: deque[Fix]) -> bool:
        """A fix refused as a jump joins the run of such fixes; when the run holds ``REACQUIRE_FIXES``
        that agree with each other, they replace the track (returns True: take this fix)."""
        run = self.refused_run.setdefault(fix.vehicle, [])
        if run and (fix.stamp_s <= run[-1].stamp_s or _jumped(run[-1], fix, self.frame, self.core.max_ugv_speed_m_s)):
            run.clear()
        run.append(fix)
        if len(run) < REACQUIRE_FIXES:
            return False
        log.warning("%s's fixes jumped and stayed: its track starts again from them", fix.vehicle)
        track.clear()
        track.extend(run[:-1])
        run.clear()
        return True

    def on_plan(self, key: str, plan: Plan) -> None:
        if not self.is_ugv(plan.vehicle):
            return
        if not sender_ok(key, plan.vehicle):
            self.bus.reject(key, f"a plan for {plan.vehicle} under another vehicle's key")
            return
        with self._lock:
            self.plans[plan.vehicle] = plan

    def on_alive(self, key: str, alive: bool) -> None:
        v = keys.vehicle_of(key)
        if v is None or not self.is_ugv(v):
            return
        with self._lock:
            if alive:
                self.dead.discard(v)
            else:
                self.dead.add(v)
                self.fixes.pop(v, None)
                self.plans.pop(v, None)
        if alive:
            log.info("UGV %s is alive", v)
        else:
            log.warning("UGV %s lost (liveliness): no longer a landmark", v)

    def on_detections(self, key: str, det: Detections) -> None:
        if not sender_ok(key, det.vehicle, self.lc.uav):
            self.bus.reject(key, f"detections from {det.vehicle} under another vehicle's key")
            return
        self.frames.put(det)

    # --- work ---------------------------------------------------------------------------------------
    def tracks(self) -> dict[str, UgvTrack]:
        with self._lock:
            fixes = {v: list(d) for v, d in self.fixes.items() if v not in self.dead and d}
            plans = {v: p for v, p in self.plans.items() if v not in self.dead}
            latency = {v: float(np.median(d)) for v, d in self.latency_s.items() if d}
        return {v: ugv_track(self.frame, fl, plans.get(v), latency.get(v, 0.0)) for v, fl in fixes.items()}

    def observation(self, det: Detections) -> FrameObservation:
        blobs = det.blobs
        if len(blobs) > self.lc.max_blobs:   # the largest: a crowd is big, noise is small
            keep = np.sort(np.argsort(-blobs.area_px, kind="stable")[: self.lc.max_blobs])
            self.counts.add("blobs_dropped", len(blobs) - len(keep))
            blobs = blobs[keep]
        pose = None if det.pose is None else pose_prior(det.pose, self.frame, det.width_px, det.height_px, det.focal_px)
        return FrameObservation(det.stamp_s, det.landmarks, blobs, det.sigma_color_px, det.sigma_ugv_blob_px,
                                det.sigma_crowd_blob_px, pose, det.focal_px / det.alt_agl_m if det.alt_agl_m > 0 else None,
                                det.sigma_crowd_blob_frame_px)

    def process(self, det: Detections) -> Crowds | None:
        """One frame: the core step, the crowd grouping, and the Crowds message (published)."""
        if self.frame is None:
            self.counts.add("no_origin")
            return None
        t0 = time.perf_counter()
        self.state, res = localize_step(self.state, self.observation(det), self.tracks(), self.core)
        # the longest-seen crowd first: a UGV that follows one crowd follows that one
        self.grouping, reported = report_crowds(self.grouping, res.crowds, det.stamp_s, self.grouping_cfg,
                                                res.placement_shift_en_m)
        msg = Crowds(self.cfg.id, det.vehicle, det.stamp_s, res.quality.value, res.landmarks_used,
                     res.outlier_landmarks, tuple(crowd_message(self.frame, r) for r in reported))
        self.step_us.append((time.perf_counter() - t0) * 1e6)
        self.last_quality = res.quality.value
        self.counts.add("frames")
        self.bus.publish(self.out_key, msg)
        self.counts.add("crowds_published")
        return msg

    def step(self, timeout_s: float) -> None:
        det = self.frames.take(timeout_s)
        if det is not None:
            self.process(det)

    def workers(self) -> list[tuple[str, Callable[[StopFlag], None]]]:
        return []

    def metrics(self) -> dict[str, float]:
        us = np.array(self.step_us) if self.step_us else np.zeros(1)
        with self._lock:
            dead = len(self.dead)
            live = sum(1 for v, d in self.fixes.items() if d and v not in self.dead)
        out = {**self.counts.as_dict(), "step_us_p50": float(np.median(us)), "step_us_p99": float(np.percentile(us, 99)),
               "dropped_frames": float(self.frames.dropped), "ugvs_tracked": float(live), "ugvs_lost": float(dead)}
        out.update({f"fixes_refused_{k}": v for k, v in self.refusals.as_dict().items()})
        return out

    def link_state(self) -> str:
        return "none"

    def note(self) -> str:
        with self._lock:
            dead = ",".join(sorted(self.dead)) or "-"
        return f"quality={self.last_quality} landmarks_lost={dead} for {self.lc.uav}"
