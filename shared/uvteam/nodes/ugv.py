"""A UGV service's logic: its autopilot -> fix on the bus; the team's fixes and the localizer's crowds ->
station plan -> mission -> its autopilot -> plan on the bus; with a forward camera, HOG people
detection -> people geolocated by the triangle rule (:mod:`uvteam.ugv_localize`).

Phases, called in this order by the service shell's loop (:meth:`UgvNode.step`) and by the experiment:
:meth:`publish_fix` (a new autopilot state becomes a Fix; one without a 3D fix or less accurate than
``max_h_acc_m`` is not published), :meth:`tick` (once per tracking interval, :meth:`plan` queues a
mission), :meth:`exchange_mission` (upload, read back, publish the plan: MAVLink round trips, so a
thread of its own in the service), :meth:`people_frame` (per camera frame, a thread of its own).

What the planner plans around: the localizer's longest-seen crowd while it is fresh (``crowd_stale_s``),
else the point under the UAV (its fix: stations in the UAV's view let the localizer find the crowd
again), else the team's centroid. Crowds are taken only from the team's localizer under its own key.

Focal length for the triangle rule: the paper's calibration f = D*h/H from a person of
``person_height_m`` at ``camera_ref_distance_m`` whose detector box is ``camera_ref_box_height_px``
tall; without one, from ``camera_hfov_deg`` scaled by the HOG window's height over the person's in it
(128/96), since the rule uses the box's height. A frame is geolocated only while the heading is known.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import keys
from ..autopilot import Autopilot, MissionItem, fix_from_state
from ..bus import Bus, RateLimitedLog
from ..camera import PinholeCamera
from ..config import VehicleConfig
from ..errors import LinkError
from ..geo import LocalFrame
from ..messages import Crowds, Fix, PeopleSeen, Person
from ..mission import mission_to_plan, plan_to_mission
from ..planning import plan_stations
from ..sync import LatestSlot, StopFlag
from ..ugv_localize import focal_px_from_reference, localize_people
from . import STREAM_START_S, Counts, sender_ok

__all__ = ["UgvNode", "CrowdTarget", "MissionJob"]

log = logging.getLogger("uvteam.ugv")
HOG_BOX_OVER_PERSON = 128.0 / 96.0   # OpenCV's people window is 128 px tall around a ~96 px person
LATENCY_SAMPLES = 2000


@dataclass(frozen=True, slots=True)
class CrowdTarget:
    """The crowd this UGV keeps station around, in its own east-north frame."""

    en_m: np.ndarray
    v_en_m_s: np.ndarray
    stamp_s: float


@dataclass(frozen=True, slots=True)
class MissionJob:
    items: list[MissionItem]
    start_en_m: np.ndarray     # where the UGV was when the plan was made


class UgvNode:
    service = "ugv"

    def __init__(self, cfg: VehicleConfig, bus: Bus, autopilot: Autopilot, clock: Callable[[], float] = time.time,
                 people_detector=None) -> None:
        self.cfg, self.bus, self.autopilot, self.clock = cfg, bus, autopilot, clock
        self.u = cfg.ugv
        self.frame: LocalFrame | None = None
        self.team_fix: dict[str, Fix] = {}
        self.crowd: CrowdTarget | None = None
        self.latency_ms: deque[float] = deque(maxlen=LATENCY_SAMPLES)
        self._lock = threading.Lock()
        self.missions = LatestSlot()
        self.last_state_stamp = 0.0
        self.first_state_s: float | None = None
        self.next_plan_s = -np.inf
        self.people_detector = people_detector
        self.next_people_s = -np.inf
        self.counts = Counts("crowds_received", "fixes_published", "fixes_withheld", "plans_published",
                             "missions_failed", "people_frames", "people_seen", "people_no_heading")
        self._warn = RateLimitedLog(log)
        self.team = set(self.u.team_ugvs) | {cfg.id, self.u.uav}

    def start(self) -> None:
        self.bus.subscribe(keys.all_vehicles(self.cfg.team, "fix"), Fix, self.on_fix)
        self.bus.subscribe(keys.key(self.cfg.team, self.u.localizer, "crowds"), Crowds, self.on_crowds)

    # --- bus callbacks ------------------------------------------------------------------------------
    def on_fix(self, key: str, fix: Fix) -> None:
        if fix.vehicle not in self.team:
            return
        if not sender_ok(key, fix.vehicle):
            self.bus.reject(key, f"a fix for {fix.vehicle} under another vehicle's key")
            return
        with self._lock:
            old = self.team_fix.get(fix.vehicle)
            if old is None or fix.stamp_s > old.stamp_s:
                self.team_fix[fix.vehicle] = fix

    def on_crowds(self, key: str, msg: Crowds) -> None:
        if not sender_ok(key, msg.vehicle, self.u.localizer) or msg.uav != self.u.uav:
            self.bus.reject(key, f"crowds from {msg.vehicle} for {msg.uav}: not this team's localizer and UAV")
            return
        now = self.clock()
        self.counts.add("crowds_received")
        with self._lock:
            self.latency_ms.append((now - msg.stamp_s) * 1000.0)
            if msg.crowds and self.frame is not None:
                c = msg.crowds[0]   # the localizer lists the longest-seen crowd first
                e, n = self.frame.wgs84_to_ground(c.lat_deg, c.lon_deg)
                self.crowd = CrowdTarget(np.array([float(e), float(n)]), np.array([c.v_east_m_s, c.v_north_m_s]),
                                         msg.stamp_s)

    # --- phases ---------------------------------------------------------------------------------------
    def publish_fix(self) -> Fix | None:
        """A new autopilot state as this UGV's fix (withheld without a 3D fix or when too inaccurate, or
        when the autopilot does not say)."""
        st = self.autopilot.state()
        if st is None or st.stamp_s <= self.last_state_stamp:
            return None
        self.last_state_stamp = st.stamp_s
        if self.first_state_s is None:
            self.first_state_s = st.stamp_s
        if not st.usable_fix(self.u.max_h_acc_m):   # unknown fix type or accuracy is not usable either
            self.counts.add("fixes_withheld")
            if st.fix_type is None and st.stamp_s - self.first_state_s < STREAM_START_S:
                log.debug("fix withheld: no GPS_RAW_INT yet")   # the autopilot's stream is starting
            else:
                self._warn.warn("fix", "fix withheld: fix type %s, accuracy %s m", st.fix_type, st.h_acc_m)
            return None
        fix = fix_from_state(self.cfg.id, st)
        if self.frame is None:
            self.frame = LocalFrame(st.lat_deg, st.lon_deg, st.alt_amsl_m)
        self.bus.publish(keys.key(self.cfg.team, self.cfg.id, "fix"), fix)
        self.counts.add("fixes_published")
        return fix

    def tick(self, now_s: float) -> None:
        if now_s >= self.next_plan_s:
            self.plan(now_s)
            self.next_plan_s = now_s + self.u.tracking_interval_s

    def _centre(self, now_s: float, en: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """What to keep station around: the crowd, else the point under the UAV, else the team."""
        with self._lock:
            crowd = self.crowd
            uav_fix = self.team_fix.get(self.u.uav)
        if crowd is not None and now_s - crowd.stamp_s < self.u.crowd_stale_s:
            return crowd.en_m + crowd.v_en_m_s * (now_s - crowd.stamp_s), crowd.v_en_m_s
        if uav_fix is not None and now_s - uav_fix.stamp_s < self.u.fix_stale_s:
            v = np.array([uav_fix.v_east_m_s or 0.0, uav_fix.v_north_m_s or 0.0], float)
            return np.array(self.frame.wgs84_to_ground(uav_fix.lat_deg, uav_fix.lon_deg), float), v
        return np.mean(list(en.values()), 0), np.zeros(2)

    def plan(self, now_s: float) -> MissionJob | None:
        """Stations around the crowd for the team as this UGV knows it; its own leg queued as a mission."""
        if self.frame is None:
            return None
        with self._lock:
            fixes = {v: f for v, f in self.team_fix.items() if v in set(self.u.team_ugvs) | {self.cfg.id}
                     and now_s - f.stamp_s < self.u.fix_stale_s}
        if self.cfg.id not in fixes:
            return None
        en = {v: np.array(self.frame.wgs84_to_ground(f.lat_deg, f.lon_deg), float) for v, f in fixes.items()}
        centre, vel = self._centre(now_s, en)
        view = (self.u.view_half_width_m, self.u.view_half_height_m) if self.u.view_half_width_m > 0 else None
        plans = plan_stations(centre, vel, en, now_s, radius_m=self.u.station_radius_m, view_half_m=view,
                              horizon_s=self.u.horizon_s, step_s=self.u.tracking_interval_s,
                              max_speed_m_s=self.u.max_speed_m_s)
        job = MissionJob(plan_to_mission(plans[self.cfg.id], self.frame), en[self.cfg.id])
        self.missions.put(job)   # only the newest mission matters
        return job

    def exchange_mission(self, timeout_s: float = 0.0, stop: StopFlag | None = None) -> bool:
        """Upload the newest queued mission, read back what the autopilot holds, publish it as the plan."""
        job = self.missions.take(timeout_s)
        if job is None:
            return False
        try:
            self.autopilot.upload_mission(job.items)
            held = self.autopilot.download_mission()
        except LinkError as exc:
            self.counts.add("missions_failed")
            if stop is None or not stop.is_set():
                self._warn.warn("mission", "mission exchange failed: %s", exc)
            return False
        plan = mission_to_plan(self.cfg.id, held, self.frame, job.start_en_m, self.clock(), self.u.max_speed_m_s)
        self.bus.publish(keys.key(self.cfg.team, self.cfg.id, "plan"), plan)
        self.counts.add("plans_published")
        return True

    def focal_px(self, width_px: int, height_px: int) -> float:
        u = self.u
        if u.camera_ref_distance_m > 0 and u.camera_ref_box_height_px > 0:
            return focal_px_from_reference(u.camera_ref_distance_m, u.camera_ref_box_height_px, u.person_height_m)
        return PinholeCamera(width_px, height_px, u.camera_hfov_deg).focal_px * HOG_BOX_OVER_PERSON

    def people_frame(self, stamp_s: float, img: np.ndarray) -> PeopleSeen | None:
        """One forward-camera frame -> HOG people -> geolocated with this UGV's newest state -> the bus."""
        now = self.clock()
        if now < self.next_people_s:
            return None
        self.next_people_s = now + (1.0 / self.u.people_rate_hz if self.u.people_rate_hz > 0 else 0.0)
        st = self.autopilot.state()
        if st is None or self.frame is None:
            return None
        if st.heading_deg is None:   # unknown is not north
            self.counts.add("people_no_heading")
            return None
        found = self.people_detector.detect(img)
        h, w = img.shape[:2]
        pf = localize_people(self.frame, st.lat_deg, st.lon_deg, (st.heading_deg + self.u.camera_yaw_deg) % 360.0,
                             self.focal_px(w, h), w / 2.0, found.feet_xy_px[:, 0], found.height_px, self.u.person_height_m)
        people = tuple(Person(float(la), float(lo), float(d), float(b))
                       for la, lo, d, b in zip(pf.lat_deg, pf.lon_deg, pf.distance_m, pf.bearing_deg))
        msg = PeopleSeen(self.cfg.id, stamp_s, people)
        self.bus.publish(keys.key(self.cfg.team, self.cfg.id, "people"), msg)
        self.counts.add("people_frames")
        self.counts.add("people_seen", len(people))
        return msg

    # --- the service loop's interface ---------------------------------------------------------------
    def step(self, timeout_s: float) -> None:
        self.publish_fix()
        self.tick(self.clock())
        if timeout_s > 0:
            time.sleep(timeout_s)

    def workers(self) -> list[tuple[str, Callable[[StopFlag], None]]]:
        def missions(stop: StopFlag) -> None:
            while not stop.is_set():
                self.exchange_mission(0.2, stop)
        return [("mission", missions)]

    def metrics(self) -> dict[str, float]:
        with self._lock:
            lat = np.array(self.latency_ms) if self.latency_ms else None
        out = self.counts.as_dict()
        if lat is not None:
            out["crowds_latency_p50_ms"] = float(np.percentile(lat, 50))
            out["crowds_latency_p99_ms"] = float(np.percentile(lat, 99))
        return out

    def link_state(self) -> str:
        return self.autopilot.link_state

    def note(self) -> str:
        with self._lock:
            crowd = self.crowd
        return f"following {self.u.localizer}'s crowds" + ("" if crowd is None else f"; crowd at {crowd.stamp_s:.1f}")
