"""The agent-based world: crowds, UGVs following their missions, the UAV and its camera. Pure and seeded.

Everything random comes from one ``np.random.Generator`` seeded per run; time is passed in by the
caller (``step(dt_s)``), so the same world drives the real-time simulator service and the in-process
experiment alike.

Modelling choices (each a scenario field or stated here):
- crowd members keep their place in the crowd with a slow personal wander (0.3 m, Ornstein-Uhlenbeck)
  around offsets drawn with ``spread_m``; a crowd moves at its velocity (or a speed drawn from
  ``speed_range_m_s`` with the heading kept), straight on, or winding where ``turn_sigma_deg_s`` > 0:
  its velocity turned at a rate that wanders (Ornstein-Uhlenbeck, 1-sigma ``turn_sigma_deg_s``,
  ``TURN_TAU_S`` correlation), drawn from its own generator (seed, 0x7E2) so the world's stream is the
  same with and without it (distractors are still placed along the straight path);
- a UGV drives towards its current mission waypoint at the leg's commanded speed, limited to
  ``station_speed_m_s`` while it is on station and to ``approach_speed_m_s`` otherwise (approaching,
  or catching up after falling behind). On station means within 3 m of the station ring *and* within
  reach of its next waypoint (3 m plus one second at station speed): a UGV that has slid round the ring
  behind its own station is not on station, so a crowd faster than the station speed does not sweep
  the team to its trailing side;
- the UAV keeps the crowd centroid under the camera with a first-order lag (``follow_time_constant_s``)
  plus a slow hover wander (``hover_wobble_m``, 3 s correlation); gimbal jitter is fresh every frame;
- terrain: height = relief/2 * sin(2 pi e / wavelength) * cos(2 pi n / wavelength) above the plane;
- UGV roof labels and the visible centre of a person both sit 1.0 m above the ground;
- GNSS: white noise ``sigma_m`` plus a random-walk bias, plus a bias that drifts as a receiver's error
  does (first-order Gauss-Markov: steady 1-sigma ``bias_sigma_m`` per axis, drawn at the start, and
  correlation time ``bias_time_s``; from its own generator (seed, 0x6B5), so the world's stream is the
  same with and without it), at ``fix_rate_hz``, ``latency_s`` late, none during ``dropouts``;
- the camera's roll/pitch is the scenario's fixed gimbal tilt (``uav.tilt_roll_deg``/``tilt_pitch_deg``,
  default 0), plus the gimbal's residual tilt for the run (``uav.attitude_sigma_deg`` per axis, default 0,
  from its own generator (seed, 0xA771) so the world's stream is the same with and without it; the
  autopilot does not report it), plus the fresh jitter;
- distractors (``[distractors]``, none by default): static things in the UGVs' label colours, placed
  once per run from their own generator (seed, 0xD15), so the world's own random stream is the same
  with and without them. Each carries a square patch of ``ugvs.label_side_m`` in a label colour
  (paint gain 0.85-1.0): a painted *marking* on the ground, a parked *vehicle* (4.4 x 1.8 m, 1.5 m
  tall, the patch on its roof) or a *roof* (a 6 x 6 m flat-roofed shed, 3 m tall, the patch on it).
  ``on_route`` ones stand on the UGVs' station ring (``station_radius_m`` +- 1.5 m) around the first
  crowd's centre at a random time of the run; ``near_crowd`` ones within ``near_crowd_m`` of a
  crowd's centre at a random time (sheds are left out of both when another kind is allowed: UGVs
  do not drive, nor people walk, through buildings); ``scattered`` ones anywhere over the crowds'
  paths plus half a nadir footprint. Colours (and kinds) cycle through their list from a random
  start in each group, so a group of at least as many as there are colours has every colour.
  The sensor model (:meth:`SimWorld.sense`) does not see them: they are for rendered frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uvteam.camera import CameraPose, PinholeCamera, project
from uvteam.blobs import Blobs, Landmarks
from uvteam.detector_noise import SENSOR_MODEL_NOISE
from uvteam.geo import LocalFrame
from uvteam.scenario import Scenario

__all__ = ["SimWorld", "SensorFrame", "Distractor", "place_distractors", "DISTRACTOR_SHAPES"]

ROOF_HEIGHT_M = 1.0
PERSON_CENTRE_HEIGHT_M = 1.0
PERSON_RADIUS_M = 0.3
MEMBER_WANDER_M = 0.3
TURN_TAU_S = 4.0  # a winding crowd's turn rate keeps its sign for a few seconds, as a path bends
WOBBLE_TAU_S = 3.0
MISS_PROB = 0.02
FALSE_BLOBS_PER_FRAME = 0.05
STATION_BAND_M = 3.0
STATION_LEAD_S = 1.0
MOVING_M_S = 0.2  # frame differencing sees a UGV only when it moves
SENSOR_UGV_BLOB_M2 = 7.0     # a moving UGV's blob as the pixel pipeline sees it (median 7.1 m2 at 1.5-3 m/s,
                             # docs/own_blob_area.py); crowd and false blobs keep area 1 (not modelled)
GNSS_VEL_SIGMA_M_S = 0.05
ROUTE_BAND_M = 1.5           # on-route distractors: this close to the station ring
PAINT_GAIN = (0.85, 1.0)     # distractor paint: brightness of a label colour (hue and saturation kept)


@dataclass(frozen=True, slots=True)
class DistractorShape:
    length_m: float          # footprint along the heading (0: only the patch, painted on the ground)
    width_m: float
    height_m: float          # where the patch is: top of the thing above the ground


DISTRACTOR_SHAPES = {
    "marking": DistractorShape(0.0, 0.0, 0.0),
    "vehicle": DistractorShape(4.4, 1.8, 1.5),
    "roof": DistractorShape(6.0, 6.0, 3.0),
}


@dataclass(frozen=True, slots=True)
class Distractor:
    """A static label-coloured thing: its ``kind`` (:data:`DISTRACTOR_SHAPES`), the ``color`` of its
    patch (a label colour), where it is and why (``group``: on_route | near_crowd | scattered)."""

    kind: str
    color: str
    east_m: float
    north_m: float
    heading_deg: float
    paint_gain: float        # the patch is LABEL_BGR[color] times this
    body_grey: float         # vehicle/roof body brightness, 0-255
    group: str


def place_distractors(sc: Scenario, seed: int, crowd_c: np.ndarray, crowd_v: np.ndarray,
                      footprint_m: tuple[float, float]) -> tuple[Distractor, ...]:
    """The scenario's distractors for this seed (see the module docstring); () when it has none."""
    d = sc.distractors
    if d.total == 0:
        return ()
    rng = np.random.default_rng([seed, 0xD15])
    colors = d.colors or tuple(sc.ugvs.colors)
    dur = sc.run.duration_s
    out: list[Distractor] = []

    def centre(k: int, t: float) -> np.ndarray:
        return crowd_c[k] + crowd_v[k] * t

    ends = np.vstack([crowd_c, crowd_c + crowd_v * dur])
    lo = ends.min(0) - np.array(footprint_m) / 2
    hi = ends.max(0) + np.array(footprint_m) / 2
    walkable = tuple(k for k in d.kinds if k != "roof") or d.kinds   # no shed where UGVs drive or people walk
    for group, count, kinds in (("on_route", d.on_route, walkable), ("near_crowd", d.near_crowd, walkable),
                                ("scattered", d.scattered, d.kinds)):
        c0, k0 = int(rng.integers(len(colors))), int(rng.integers(len(kinds)))
        for j in range(count):
            if group == "on_route":
                r = sc.ugvs.station_radius_m + rng.uniform(-ROUTE_BAND_M, ROUTE_BAND_M)
                a = rng.uniform(0, 2 * np.pi)
                p = centre(0, rng.uniform(0, dur)) + r * np.array([math.sin(a), math.cos(a)])
            elif group == "near_crowd":
                k = int(rng.integers(len(crowd_c)))
                r = d.near_crowd_m * math.sqrt(rng.uniform())
                a = rng.uniform(0, 2 * np.pi)
                p = centre(k, rng.uniform(0, dur)) + r * np.array([math.sin(a), math.cos(a)])
            else:
                p = rng.uniform(lo, hi)
            out.append(Distractor(kinds[(k0 + j) % len(kinds)], colors[(c0 + j) % len(colors)], float(p[0]), float(p[1]),
                                  float(rng.uniform(0, 360)), float(rng.uniform(*PAINT_GAIN)),
                                  float(rng.uniform(60, 200)), group))
    return tuple(out)


@dataclass(frozen=True)
class SensorFrame:
    """What the sensor model reports for a frame, labelled by roof color, as the vision pipeline would."""

    stamp_s: float
    landmarks: Landmarks                         # by roof color
    blobs: Blobs                                 # ``ugv``: the roof color seen in a blob, or ""
    blob_kind: tuple[str, ...]                   # "ugv:<color>" | "crowd:<k>" | "false" (truth, for diagnostics)


class SimWorld:
    def __init__(self, sc: Scenario, seed: int) -> None:
        self.sc = sc
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        rng = self.rng
        a = sc.uav.attitude_sigma_deg
        self.attitude_bias_deg = np.random.default_rng([seed, 0xA771]).normal(0, a, 2) if a > 0 else np.zeros(2)
        self.frame = LocalFrame(sc.world.origin_lat_deg, sc.world.origin_lon_deg, sc.world.ground_amsl_m)
        self.camera = PinholeCamera(sc.camera.width_px, sc.camera.height_px, sc.camera.hfov_deg)
        self.t = 0.0
        # crowds
        self.crowd_c = np.array([[c.start_east_m, c.start_north_m] for c in sc.crowds], float)
        v = np.array([[c.velocity_east_m_s, c.velocity_north_m_s] for c in sc.crowds], float)
        for k, c in enumerate(sc.crowds):
            if len(c.speed_range_m_s) == 2:
                sp = rng.uniform(*c.speed_range_m_s)
                v[k] = v[k] / max(np.linalg.norm(v[k]), 1e-9) * sp
        self.crowd_v = v
        self.turn_sigma_rad_s = np.radians([c.turn_sigma_deg_s for c in sc.crowds])
        self.turn_rng = np.random.default_rng([seed, 0x7E2])
        self.turn_z = self.turn_rng.normal(0.0, 1.0, len(sc.crowds))   # turn rate / its sigma: OU, unit variance
        self.base_off = [rng.normal(0, c.spread_m / np.sqrt(2), (c.members, 2)) for c in sc.crowds]
        self.wander = [np.zeros((c.members, 2)) for c in sc.crowds]
        # UGVs around the first crowd
        n = sc.ugvs.count
        ang = rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.arange(n) / n + rng.uniform(-0.4, 0.4, n)
        dist = rng.uniform(*sc.ugvs.initial_distance_m, n)
        self.ugv_p = self.crowd_c[0] + np.column_stack([dist * np.sin(ang), dist * np.cos(ang)])
        self.ugv_heading_deg = rng.uniform(0, 360, n)
        self.ugv_speed = np.zeros(n)
        self.ugv_v = np.zeros((n, 2))
        self.ugv_on_station = np.zeros(n, bool)
        self.missions: list[list[tuple[float, float, float]]] = [[] for _ in range(n)]  # (e, n, speed)
        self.wp_index = np.zeros(n, int)
        self.gnss_bias = np.zeros((n, 2))
        self.gm_rng = np.random.default_rng([seed, 0x6B5])
        self.gnss_drift = self.gm_rng.normal(0.0, sc.gnss.bias_sigma_m, (n, 2)) if sc.gnss.bias_sigma_m > 0 \
            else np.zeros((n, 2))
        # UAV
        self.uav_p = self.crowd_centroids()[0].copy()
        self.wobble = np.zeros(2)
        # static distractors, from their own generator
        self.distractors = place_distractors(sc, seed, self.crowd_c, self.crowd_v,
                                             self.camera.footprint_m(sc.uav.altitude_agl_m))

    # --- geometry -----------------------------------------------------------------------------
    def terrain_up_m(self, en) -> np.ndarray:
        en = np.atleast_2d(en)
        a, lam = self.sc.world.terrain_relief_m / 2.0, self.sc.world.terrain_wavelength_m
        if a == 0:
            return np.zeros(len(en))
        return a * np.sin(2 * np.pi * en[:, 0] / lam) * np.cos(2 * np.pi * en[:, 1] / lam)

    def members(self, k: int) -> np.ndarray:
        return self.crowd_c[k] + self.base_off[k] + self.wander[k]

    def crowd_centroids(self) -> np.ndarray:
        return np.array([self.members(k).mean(0) for k in range(len(self.sc.crowds))])

    def truth_crowds(self) -> list[tuple[np.ndarray, int]]:
        """(centroid, members) per scored crowd; crowds whose members mingle (< 2 m) are one."""
        return [(g.mean(0), len(g)) for g in self._blob_groups()]

    def _blob_groups(self) -> list[np.ndarray]:
        """Members of each crowd as frame differencing sees them: mingling crowds make one blob."""
        n = len(self.sc.crowds)
        mem = [self.members(k) for k in range(n)]
        group = list(range(n))
        for i in range(n):
            for j in range(i + 1, n):
                if np.sqrt(((mem[i][:, None] - mem[j][None]) ** 2).sum(-1)).min() < 2.0:
                    gi, gj = group[i], group[j]
                    group = [gi if g == gj else g for g in group]
        return [np.vstack([mem[k] for k in range(n) if group[k] == g]) for g in sorted(set(group))]

    # --- dynamics -------------------------------------------------------------------------------
    def set_mission(self, i: int, waypoints: list[tuple[float, float, float]]) -> None:
        self.missions[i] = list(waypoints)
        self.wp_index[i] = 0

    def step(self, dt: float) -> None:
        rng, sc = self.rng, self.sc
        self.t += dt
        self.crowd_c = self.crowd_c + self.crowd_v * dt
        if self.turn_sigma_rad_s.any():
            a = np.exp(-dt / TURN_TAU_S)
            self.turn_z = a * self.turn_z + np.sqrt(1 - a * a) * self.turn_rng.normal(0.0, 1.0, len(self.turn_z))
            turn = self.turn_z * self.turn_sigma_rad_s * dt     # radians, counter-clockwise seen from above
            c, s_ = np.cos(turn), np.sin(turn)
            ve, vn = self.crowd_v[:, 0], self.crowd_v[:, 1]
            self.crowd_v = np.column_stack([c * ve - s_ * vn, s_ * ve + c * vn])
        a = np.exp(-dt / 5.0)
        for k in range(len(self.wander)):
            self.wander[k] = a * self.wander[k] + np.sqrt(1 - a * a) * rng.normal(0, MEMBER_WANDER_M, self.wander[k].shape)
        cents = self.crowd_centroids()
        for i in range(sc.ugvs.count):
            d = np.sqrt(((cents - self.ugv_p[i]) ** 2).sum(1)).min()
            mission, w = self.missions[i], self.wp_index[i]
            to_wp = np.hypot(*(np.array(mission[w][:2]) - self.ugv_p[i])) if w < len(mission) else 0.0
            self.ugv_on_station[i] = (abs(d - sc.ugvs.station_radius_m) <= STATION_BAND_M
                                      and to_wp <= STATION_BAND_M + sc.ugvs.station_speed_m_s * STATION_LEAD_S)
            limit = sc.ugvs.station_speed_m_s if self.ugv_on_station[i] else sc.ugvs.approach_speed_m_s
            p_before = self.ugv_p[i].copy()
            moved = 0.0
            budget = dt
            while w < len(mission) and budget > 1e-9:
                e, n, sp = mission[w]
                vec = np.array([e, n]) - self.ugv_p[i]
                dist = float(np.hypot(*vec))
                speed = min(max(sp, 0.0), limit)
                if speed <= 0:
                    break
                if dist <= speed * budget:
                    self.ugv_p[i] = np.array([e, n])
                    budget -= dist / speed
                    moved += dist
                    w += 1
                else:
                    self.ugv_p[i] = self.ugv_p[i] + vec / dist * speed * budget
                    moved += speed * budget
                    budget = 0.0
                if dist > 1e-6:
                    self.ugv_heading_deg[i] = np.degrees(np.arctan2(vec[0], vec[1])) % 360.0
            self.wp_index[i] = w
            self.ugv_speed[i] = moved / dt
            self.ugv_v[i] = (self.ugv_p[i] - p_before) / dt
        self.gnss_bias += rng.normal(0, sc.gnss.bias_walk_m_per_sqrt_s * np.sqrt(dt), self.gnss_bias.shape)
        if sc.gnss.bias_sigma_m > 0:
            a = np.exp(-dt / sc.gnss.bias_time_s)
            self.gnss_drift = a * self.gnss_drift + np.sqrt(1 - a * a) * self.gm_rng.normal(
                0.0, sc.gnss.bias_sigma_m, self.gnss_drift.shape)
        target = cents.mean(0) if sc.uav.follow != "fixed" else self.uav_p
        if sc.uav.follow == "crowd":
            self.uav_p = target.copy()
        elif sc.uav.follow == "crowd-lagged":
            self.uav_p = self.uav_p + (target - self.uav_p) * (1 - np.exp(-dt / sc.uav.follow_time_constant_s))
        b = np.exp(-dt / WOBBLE_TAU_S)
        self.wobble = b * self.wobble + np.sqrt(1 - b * b) * rng.normal(0, sc.uav.hover_wobble_m, 2)

    # --- sensors ----------------------------------------------------------------------------------
    def ugv_fix_en(self, i: int) -> np.ndarray:
        return self.ugv_p[i] + self.gnss_bias[i] + self.gnss_drift[i] + self.rng.normal(0, self.sc.gnss.sigma_m, 2)

    def ugv_fix_v(self, i: int) -> np.ndarray:
        """Doppler velocity as a receiver reports it: 5 cm/s noise."""
        return self.ugv_v[i] + self.rng.normal(0, GNSS_VEL_SIGMA_M_S, 2)

    def in_dropout(self, i: int, t_s: float) -> bool:
        return any(int(d[0]) == i and d[1] <= t_s < d[2] for d in self.sc.gnss.dropouts)

    def camera_pose(self) -> CameraPose:
        j = self.sc.uav.gimbal_jitter_deg
        roll, pitch = (self.rng.normal(0, j, 2) if j > 0 else (0.0, 0.0))
        p = self.uav_p + self.wobble
        ground = float(self.terrain_up_m(self.uav_p)[0])
        tilt_roll, tilt_pitch = self.fixed_tilt_deg()
        return CameraPose(float(p[0]), float(p[1]), ground + self.sc.uav.altitude_agl_m, 0.0,
                          float(roll) + tilt_roll, float(pitch) + tilt_pitch)

    def fixed_tilt_deg(self) -> tuple[float, float]:
        """The camera's roll and pitch without the jitter: the set tilt plus the run's residual (both 0 in
        every file that does not set them: x + 0.0 == x, frames unchanged)."""
        u, (br, bp) = self.sc.uav, self.attitude_bias_deg
        return u.tilt_roll_deg + float(br), u.tilt_pitch_deg + float(bp)

    def _in_image(self, px: np.ndarray, margin: float = 0.0) -> np.ndarray:
        w, h = self.camera.width_px, self.camera.height_px
        return (np.isfinite(px).all(-1) & (px[..., 0] >= margin) & (px[..., 0] < w - margin)
                & (px[..., 1] >= margin) & (px[..., 1] < h - margin))

    def ugv_label_enu(self) -> np.ndarray:
        up = self.terrain_up_m(self.ugv_p) + ROOF_HEIGHT_M
        return np.column_stack([self.ugv_p, up])

    def crowd_groups_px(self, pose: CameraPose) -> list[np.ndarray]:
        """Each scored crowd's members (mingling crowds as one) in the image: (N_k, 2) pixels, NaN behind."""
        return [project(self.camera, pose, np.column_stack([m, self.terrain_up_m(m) + PERSON_CENTRE_HEIGHT_M]))
                for m in self._blob_groups()]

    def sense(self, pose: CameraPose, stamp_s: float) -> SensorFrame:
        """The sensor model: what a detector would report in this frame, with noise, misses, false blobs."""
        rng, sc, cam = self.rng, self.sc, self.camera
        lm_px = project(cam, pose, self.ugv_label_enu())
        landmarks, xy, boxes, kinds, colors = {}, [], [], [], []
        px_per_m = cam.focal_px / sc.uav.altitude_agl_m
        half = 0.5 * max(sc.ugvs.length_m, sc.ugvs.width_m) * px_per_m
        areas = []
        for i, color in enumerate(sc.ugvs.colors):
            if not self._in_image(lm_px[i]):
                continue
            if rng.random() >= MISS_PROB:
                seen = tuple(lm_px[i] + rng.normal(0, SENSOR_MODEL_NOISE.color_px, 2))
                if sc.ugvs.roof_labels:   # without labels the draws are made all the same: one stream either way
                    landmarks[color] = seen
            if self.ugv_speed[i] > MOVING_M_S and rng.random() >= MISS_PROB:
                c = lm_px[i] + rng.normal(0, SENSOR_MODEL_NOISE.ugv_blob_px, 2)
                xy.append(c)
                boxes.append([c[0] - half, c[1] - half, c[0] + half, c[1] + half])
                kinds.append(f"ugv:{color}")
                areas.append(SENSOR_UGV_BLOB_M2 * px_per_m ** 2)
                colors.append(color if color in landmarks else "")  # the label lies inside its blob
        r_px = PERSON_RADIUS_M * px_per_m
        for k, px in enumerate(self.crowd_groups_px(pose)):
            vis = self._in_image(px)
            if vis.sum() < max(2, 0.5 * len(px)) or rng.random() < MISS_PROB:
                continue
            p = px[vis]
            c = p.mean(0) + rng.normal(0, SENSOR_MODEL_NOISE.crowd_blob_px, 2)
            xy.append(c)
            boxes.append([p[:, 0].min() - r_px, p[:, 1].min() - r_px, p[:, 0].max() + r_px, p[:, 1].max() + r_px])
            kinds.append(f"crowd:{k}")
            areas.append(1.0)
            colors.append("")
        for _ in range(rng.poisson(FALSE_BLOBS_PER_FRAME)):
            c = rng.uniform([0, 0], [cam.width_px, cam.height_px])
            s = rng.uniform(2, 4) * r_px
            xy.append(c)
            boxes.append([c[0] - s, c[1] - s, c[0] + s, c[1] + s])
            kinds.append("false")
            areas.append(1.0)
            colors.append("")
        blobs = Blobs(np.array(xy, float).reshape(-1, 2), np.array(boxes, float).reshape(-1, 4), np.array(areas), tuple(colors))
        return SensorFrame(stamp_s, Landmarks.from_dict(landmarks), blobs, tuple(kinds))
