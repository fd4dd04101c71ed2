"""A scenario played in time: what each vehicle's autopilot and camera deliver, and when. Pure and seeded.

The real-time simulator service (:mod:`.app`: MAVLink autopilots over UDP, frames on zenoh) and the
in-process experiment (:mod:`.experiment`: fake autopilots, the in-memory bus, simulated time) both
consume :meth:`Simulation.ticks`, so the two see the same world, the same GNSS and the same events:

- the world steps ``SUBSTEPS`` times per frame;
- GNSS fixes are captured at ``fix_rate_hz`` with the scenario's noise and bias, delivered
  ``latency_s`` later, none during drop-outs, none from a lost UGV;
- a lost UGV (``events.lose_ugv``) is reported once, at its time: its service stops for good;
- a frame is due every ``SUBSTEPS`` ticks: the camera pose, the UAV's autopilot state, the truth.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from uvteam.autopilot import MissionItem, VehicleState
from uvteam.detector_noise import SENSOR_MODEL_NOISE
from uvteam.messages import Detections, Truth, TruthCrowd, TruthUgv
from uvteam.mission import mission_legs
from uvteam.scenario import Scenario

from .world import SimWorld

__all__ = ["Simulation", "Tick", "FixDue", "SUBSTEPS", "GPS_FIX_3D", "UAV_H_ACC_M"]

SUBSTEPS = 4                 # world steps per frame
GPS_FIX_3D = 3
MIN_H_ACC_M = 0.02           # a receiver reports no better than this
UAV_H_ACC_M = 0.5


@dataclass(frozen=True, slots=True)
class FixDue:
    ugv_index: int
    state: VehicleState       # what the UGV's autopilot reports, stamped with the capture time


@dataclass(frozen=True, slots=True)
class Tick:
    t_s: float                # scenario time; the world is at this instant
    fixes: tuple[FixDue, ...]  # delivered now
    lost: tuple[int, ...]     # UGVs whose service stops now
    frame_seq: int | None     # a camera frame is due now (its sequence number), or None


class Simulation:
    def __init__(self, sc: Scenario, seed: int, t0_unix_s: float) -> None:
        self.sc, self.seed, self.t0_unix_s = sc, seed, t0_unix_s
        self.world = SimWorld(sc, seed)
        self.lock = threading.Lock()          # the real-time service steers UGVs from MAVLink threads
        self.dt_frame_s = 1.0 / sc.run.frame_rate_hz
        self.dt_s = self.dt_frame_s / SUBSTEPS
        self.lost_at = {int(i): float(t) for i, t in sc.events.lose_ugv}
        self.ground_amsl_m = sc.world.ground_amsl_m
        self._last_uav: tuple[float, np.ndarray] | None = None
        # the UAV autopilot's own errors: biases for the run (a separate stream: the world's draws stay as they were)
        self._uav_rng = np.random.default_rng([seed, 0xA77])
        u = sc.uav
        self._uav_bias = (self._uav_rng.normal(0, u.position_sigma_m, 2), float(self._uav_rng.normal(0, u.heading_sigma_deg)),
                          float(self._uav_rng.normal(0, u.alt_sigma_m)))

    def ticks(self, duration_s: float | None = None) -> Iterator[Tick]:
        sc = self.sc
        n_frames = int(round((duration_s or sc.run.duration_s) * sc.run.frame_rate_hz))
        dt_fix = 1.0 / sc.gnss.fix_rate_hz
        next_fix = 0.0
        pending: list[tuple[float, FixDue]] = []
        lost: set[int] = set()
        for k in range(n_frames * SUBSTEPS + 1):
            t = k * self.dt_s
            if k:
                with self.lock:
                    self.world.step(self.dt_s)
            now_lost = tuple(i for i, at in sorted(self.lost_at.items()) if i not in lost and t >= at - 1e-9)
            lost.update(now_lost)
            while next_fix <= t + 1e-9:
                for i in range(sc.ugvs.count):
                    if i not in lost and not self.world.in_dropout(i, next_fix):
                        pending.append((next_fix + sc.gnss.latency_s, FixDue(i, self._ugv_state(i, next_fix))))
                next_fix += dt_fix
            due = tuple(f for rel, f in pending if rel <= t + 1e-9 and f.ugv_index not in lost)
            pending = [(rel, f) for rel, f in pending if rel > t + 1e-9 and f.ugv_index not in lost]
            yield Tick(t, due, now_lost, k // SUBSTEPS if k % SUBSTEPS == 0 else None)

    def _ugv_state(self, i: int, capture_s: float) -> VehicleState:
        sc, w = self.sc, self.world
        h_acc = max(math.sqrt(sc.gnss.sigma_m ** 2 + sc.gnss.bias_sigma_m ** 2
                              + sc.gnss.bias_walk_m_per_sqrt_s ** 2 * min(capture_s, 60.0)), MIN_H_ACC_M)
        with self.lock:
            en, v = w.ugv_fix_en(i), w.ugv_fix_v(i)
            hdg = float(w.ugv_heading_deg[i])
        lat, lon = w.frame.ground_to_wgs84(en[0], en[1])
        return VehicleState(self.t0_unix_s + capture_s, "autopilot", float(lat), float(lon), self.ground_amsl_m, 0.0, hdg,
                            float(v[0]), float(v[1]), h_acc, fix_type=GPS_FIX_3D)

    def uav_state(self, pose, t_s: float) -> VehicleState:
        """What the UAV's autopilot reports at a frame: where the camera is (GNSS: the run's bias plus
        noise), its height above home and its heading (each with the run's bias), level attitude (the
        camera hangs in a stabilised gimbal: its residual tilt, the scenario's jitter, is not reported)."""
        u = self.sc.uav
        p = np.array([pose.east_m, pose.north_m])
        v = np.zeros(2)
        if self._last_uav is not None and t_s > self._last_uav[0]:
            v = (p - self._last_uav[1]) / (t_s - self._last_uav[0])
        self._last_uav = (t_s, p)
        bias_en, bias_hdg, bias_alt = self._uav_bias
        seen = p + bias_en + self._uav_rng.normal(0, 0.2 * u.position_sigma_m, 2)
        lat, lon = self.world.frame.ground_to_wgs84(seen[0], seen[1])
        heading = (pose.yaw_deg + bias_hdg) % 360.0
        return VehicleState(self.t0_unix_s + t_s, "autopilot", float(lat), float(lon), pose.up_m + self.ground_amsl_m,
                            u.altitude_agl_m + bias_alt, heading, float(v[0]), float(v[1]),
                            max(u.position_sigma_m, MIN_H_ACC_M), 0.0, 0.0, heading, fix_type=GPS_FIX_3D)

    def truth(self, t_s: float, seq: int, ugv_ids: list[str]) -> Truth:
        w = self.world
        crowds = w.truth_crowds()
        tl = [w.frame.ground_to_wgs84(c[0], c[1]) for c, _ in crowds]
        ul = w.frame.ground_to_wgs84(w.ugv_p[:, 0], w.ugv_p[:, 1])
        return Truth(self.t0_unix_s + t_s, seq,
                     tuple(TruthCrowd(float(la), float(lo), m) for (la, lo), (_, m) in zip(tl, crowds)),
                     tuple(TruthUgv(ugv_ids[i], float(ul[0][i]), float(ul[1][i])) for i in range(len(ugv_ids))))

    def sensor_detections(self, pose, t_s: float, seq: int, uav_id: str) -> Detections:
        """The sensor model's report for a frame, labelled by roof color, as the simulator publishes it."""
        sc = self.sc
        sf = self.world.sense(pose, self.t0_unix_s + t_s)
        n = SENSOR_MODEL_NOISE
        return Detections(uav_id, self.t0_unix_s + t_s, seq, sc.camera.width_px, sc.camera.height_px,
                          sc.uav.altitude_agl_m, self.world.camera.focal_px, sf.landmarks, sf.blobs,
                          n.color_px, n.ugv_blob_px, n.crowd_blob_px, None, n.crowd_blob_frame_px)

    def set_mission(self, i: int, items: list[MissionItem]) -> None:
        """A mission uploaded to UGV ``i``'s autopilot: the simulated vehicle drives its legs."""
        w = self.world
        legs = mission_legs(items, self.sc.ugvs.station_speed_m_s)
        with self.lock:
            wps = []
            for leg in legs:
                e, n = w.frame.wgs84_to_ground(leg.lat_deg, leg.lon_deg)
                wps.append((float(e), float(n), leg.speed_m_s))
            w.set_mission(i, wps)
