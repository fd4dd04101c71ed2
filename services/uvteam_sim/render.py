"""Rendering the UAV's camera frames from the world: pure functions of the world state, pose and a seeded RNG.

What a frame holds, and how it is made (every number here is a modelling choice, stated once):

- **Ground**: a desert texture generated once per run from the seed, in ground metres (north up),
  with one texel per nadir image pixel so sampling neither aliases nor blurs: four octaves of value
  noise (40, 10, 3 and 0.8 m) in sand colors, plus shrubs (dusty grey-olive discs, 0.3-1.2 m) and
  pale rocks, which give goodFeaturesToTrack its corners. Saturation stays under 100 (OpenCV scale),
  below every roof-label range even with the sensor noise, so the ground never looks like a landmark.
- **Projection**: every image pixel is cast as a ray from the camera pose (altitude, hover wobble,
  gimbal roll/pitch) onto the terrain (``SimWorld.terrain_up_m``; three fixed-point steps, exact on a
  flat plane); this is done on a grid every 8 pixels and interpolated bilinearly (the terrain is
  smooth at that scale), then the texture is sampled with ``cv2.remap``.
- **Objects**, drawn in ground coordinates and projected at their height with anti-aliased sub-pixel
  polygons: shadows first (sun at 55 deg elevation from the south-east, shadows darken the ground to
  55 %), then UGVs (a dark body ``length_m`` x ``width_m`` along the heading, with the square roof
  label of ``label_side_m`` in the UGV's color at roof height), then people (an ellipse 0.48 x 0.30 m
  of muted clothing across the direction of travel, a 0.22 m head, at 1.0 m height, sizes varying
  +-10 %).
- **Sensor**: additive Gaussian noise ``noise_sigma`` per channel (drawn from a bank made once from
  the seed, picked at a random offset each frame), then JPEG at ``jpeg_quality`` when it is > 0.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from uvteam.camera import CameraPose, R_cam_from_enu, project

from .world import PERSON_CENTRE_HEIGHT_M, ROOF_HEIGHT_M, SimWorld

__all__ = ["Renderer", "LABEL_BGR"]

# roof-label colors as a camera sees paint in sunlight (BGR)
LABEL_BGR = {
    "red": (40, 40, 205), "green": (60, 175, 45), "blue": (190, 85, 30),
    "yellow": (35, 200, 225), "magenta": (190, 55, 195), "cyan": (205, 190, 40),
}
SUN_ELEVATION_DEG = 55.0
SUN_AZIMUTH_DEG = 135.0          # the sun stands in the south-east; shadows fall to the north-west
SHADOW_GAIN = 0.55
PERSON_HEIGHT_M = 1.7
GRID_PX = 8
NOISE_BANK = 6
NOISE_PAD = 64
_SHIFT = 4                        # cv2 drawing: 4 fractional bits
_ONE = 1 << _SHIFT


def _value_noise(rng: np.random.Generator, shape: tuple[int, int], cell_px: float) -> np.ndarray:
    """Smooth noise, unit variance-ish, with features about ``cell_px`` texels across."""
    h, w = shape
    gh, gw = max(2, int(math.ceil(h / cell_px)) + 2), max(2, int(math.ceil(w / cell_px)) + 2)
    g = rng.standard_normal((gh, gw)).astype(np.float32)
    up = cv2.resize(g, (int(gw * cell_px), int(gh * cell_px)), interpolation=cv2.INTER_CUBIC)
    return up[:h, :w]


def make_ground_texture(rng: np.random.Generator, size_px: tuple[int, int], texel_m: float) -> np.ndarray:
    """A desert ground texture (BGR uint8), ``size_px`` = (rows, cols), ``texel_m`` metres per texel."""
    h, w = size_px
    n = np.zeros((h, w), np.float32)
    for scale_m, amp in ((40.0, 0.55), (10.0, 0.35), (3.0, 0.25), (0.8, 0.18)):
        cell = max(scale_m / texel_m, 1.5)
        n += amp * _value_noise(rng, (h, w), cell)
    sand_dark = np.array([95, 128, 150], np.float32)     # BGR
    sand_light = np.array([150, 185, 205], np.float32)
    a = np.clip(0.5 + 0.35 * n, 0.0, 1.0)[..., None]
    tex = sand_dark + a * (sand_light - sand_dark)
    tex = np.clip(tex, 0, 255).astype(np.uint8)
    area_m2 = h * w * texel_m * texel_m
    # shrubs: dusty olive discs (desert scrub is grey-green: saturation ~0.15); rocks: pale grey discs
    for count, r_lo, r_hi, l_lo, l_hi, tint in (
            (int(area_m2 * 0.012), 0.3, 1.2, 55.0, 95.0, (0.84, 1.0, 0.95)),
            (int(area_m2 * 0.006), 0.15, 0.5, 175.0, 210.0, (0.97, 0.99, 1.0))):
        cx = rng.uniform(0, w, count)
        cy = rng.uniform(0, h, count)
        r = rng.uniform(r_lo, r_hi, count) / texel_m
        col = np.outer(rng.uniform(l_lo, l_hi, count), tint)
        for x, y, rr, c in zip(cx, cy, r, col):
            cv2.circle(tex, (int(x * _ONE), int(y * _ONE)), max(int(rr * _ONE), _ONE // 2),
                       tuple(float(v) for v in c), -1, cv2.LINE_AA, _SHIFT)
    return cv2.GaussianBlur(tex, (0, 0), 0.6)


def _ellipse_m(centre, along, half_a_m: float, half_b_m: float, n: int = 12) -> np.ndarray:
    """(n, 2) ground points of an ellipse with semi-axis ``half_a_m`` along unit vector ``along``."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    u = np.asarray(along, float)
    v = np.array([-u[1], u[0]])
    return centre + np.outer(half_a_m * np.cos(t), u) + np.outer(half_b_m * np.sin(t), v)


class Renderer:
    """Draws the UAV camera frame (BGR uint8, camera size) for a world. One per run."""

    def __init__(self, world: SimWorld, rng: np.random.Generator) -> None:
        sc = world.sc
        self.world, self.rng, self.sc = world, rng, sc
        cam = world.camera
        self.gsd_m = sc.uav.altitude_agl_m / cam.focal_px
        self.texel_m = self.gsd_m
        # the ground the camera can see during the run: every crowd's path, the UAV's lag, the footprint
        fw, fh = cam.footprint_m(sc.uav.altitude_agl_m)
        pts = [world.crowd_c, world.crowd_c + world.crowd_v * sc.run.duration_s]
        lo = np.min(np.vstack(pts), 0) - (max(fw, fh) / 2 * 1.25 + 30.0)
        hi = np.max(np.vstack(pts), 0) + (max(fw, fh) / 2 * 1.25 + 30.0)
        self.west_m, self.north_top_m = float(lo[0]), float(hi[1])
        cols = int(math.ceil((hi[0] - lo[0]) / self.texel_m))
        rows = int(math.ceil((hi[1] - lo[1]) / self.texel_m))
        self.texture = make_ground_texture(rng, (rows, cols), self.texel_m)
        # per-person look, fixed for the run
        self.person_bgr = [rng.uniform((25, 25, 25), (110, 105, 120), (c.members, 3)) for c in sc.crowds]
        self.person_scale = [rng.uniform(0.9, 1.1, c.members) for c in sc.crowds]
        # noise bank
        self.noise_sigma = float(sc.camera.noise_sigma)
        if self.noise_sigma > 0:
            shape = (NOISE_BANK, cam.height_px + NOISE_PAD, cam.width_px + NOISE_PAD, 3)
            z = rng.normal(0.0, self.noise_sigma, shape)
            self._noise_pos = np.clip(np.rint(z), 0, 255).astype(np.uint8)
            self._noise_neg = np.clip(np.rint(-z), 0, 255).astype(np.uint8)
        el, az = math.radians(SUN_ELEVATION_DEG), math.radians(SUN_AZIMUTH_DEG)
        # shadows fall away from the sun: unit vector (east, north)
        self.shadow_dir = -np.array([math.sin(az), math.cos(az)])
        self.shadow_per_m = 1.0 / math.tan(el)
        h, w = cam.height_px, cam.width_px
        # grid samples where cv2.resize puts source pixel centres, one more beyond each edge, so that the
        # bilinear upsampling is exact interpolation everywhere in the image (no clamped border rows)
        self._gx = (np.arange(-1, int(math.ceil(w / GRID_PX)) + 1) + 0.5) * GRID_PX - 0.5
        self._gy = (np.arange(-1, int(math.ceil(h / GRID_PX)) + 1) + 0.5) * GRID_PX - 0.5

    # --- ground ------------------------------------------------------------------------------------
    def ground_maps(self, pose: CameraPose) -> tuple[np.ndarray, np.ndarray]:
        """Texture coordinates (float32 maps for cv2.remap) of every image pixel."""
        cam = self.world.camera
        u, v = np.meshgrid(self._gx, self._gy)
        K_inv = np.linalg.inv(cam.K)
        rays_cam = np.stack([u, v, np.ones_like(u)], -1) @ K_inv.T
        d = rays_cam @ R_cam_from_enu(pose)             # camera -> ENU (R is orthonormal)
        c = np.array([pose.east_m, pose.north_m, pose.up_m])
        du = np.where(d[..., 2] < -1e-6, d[..., 2], -1e-6)
        ground = float(self.world.terrain_up_m(c[:2])[0])
        t = (ground - c[2]) / du
        for _ in range(3 if self.sc.world.terrain_relief_m > 0 else 0):
            e = c[0] + t * d[..., 0]
            n = c[1] + t * d[..., 1]
            hgt = self.world.terrain_up_m(np.column_stack([e.ravel(), n.ravel()])).reshape(e.shape)
            t = (hgt - c[2]) / du
        e = c[0] + t * d[..., 0]
        n = c[1] + t * d[..., 1]
        mx = ((e - self.west_m) / self.texel_m - 0.5).astype(np.float32)
        my = ((self.north_top_m - n) / self.texel_m - 0.5).astype(np.float32)
        size = (len(self._gx) * GRID_PX, len(self._gy) * GRID_PX)
        g, w, h = GRID_PX, cam.width_px, cam.height_px
        return (cv2.resize(mx, size, interpolation=cv2.INTER_LINEAR)[g:g + h, g:g + w],
                cv2.resize(my, size, interpolation=cv2.INTER_LINEAR)[g:g + h, g:g + w])

    # --- objects -----------------------------------------------------------------------------------
    def _poly_px(self, pose: CameraPose, en: np.ndarray, up: np.ndarray | float) -> np.ndarray | None:
        up_arr = np.broadcast_to(np.asarray(up, float), (len(en),))
        px = project(self.world.camera, pose, np.column_stack([en, up_arr]))
        if not np.isfinite(px).all():
            return None
        return np.rint(px * _ONE).astype(np.int32)

    def render(self, pose: CameraPose) -> np.ndarray:
        world, sc = self.world, self.sc
        cam = world.camera
        mx, my = self.ground_maps(pose)
        frame = cv2.remap(self.texture, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
        # shadows: one grey layer multiplied in
        shade = np.full((cam.height_px, cam.width_px), 255, np.uint8)
        gain = int(255 * SHADOW_GAIN)
        people = []
        for k in range(len(sc.crowds)):
            m = world.members(k)
            ground = world.terrain_up_m(m)
            v = world.crowd_v[k]
            along = v / np.linalg.norm(v) if np.linalg.norm(v) > 1e-6 else np.array([0.0, 1.0])
            for j in range(len(m)):
                s = self.person_scale[k][j]
                length = PERSON_HEIGHT_M * s * self.shadow_per_m
                poly = self._poly_px(pose, _ellipse_m(m[j] + self.shadow_dir * length / 2, self.shadow_dir,
                                                      length / 2 + 0.1, 0.2 * s), ground[j])
                if poly is not None:
                    cv2.fillPoly(shade, [poly], gain, cv2.LINE_AA, _SHIFT)
                people.append((m[j], ground[j], along, s, self.person_bgr[k][j]))
        ugv_up = world.terrain_up_m(world.ugv_p)
        bodies = []
        for i, color in enumerate(sc.ugvs.colors):
            hd = math.radians(world.ugv_heading_deg[i])
            fwd = np.array([math.sin(hd), math.cos(hd)])
            side = np.array([fwd[1], -fwd[0]])
            half_l, half_w = sc.ugvs.length_m / 2, sc.ugvs.width_m / 2
            corners = np.array([fwd * a * half_l + side * b * half_w for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1))])
            sh = ROOF_HEIGHT_M * self.shadow_per_m * self.shadow_dir
            hull = cv2.convexHull(np.vstack([corners, corners + sh]).astype(np.float32)).reshape(-1, 2)
            poly = self._poly_px(pose, world.ugv_p[i] + hull, ugv_up[i])
            if poly is not None:
                cv2.fillPoly(shade, [poly], gain, cv2.LINE_AA, _SHIFT)
            lab = sc.ugvs.label_side_m / 2
            label = np.array([fwd * a * lab + side * b * lab for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1))])
            bodies.append((world.ugv_p[i] + corners, world.ugv_p[i] + label, ugv_up[i] + ROOF_HEIGHT_M, color))
        frame = cv2.multiply(frame, cv2.merge([shade, shade, shade]), scale=1.0 / 255.0)
        for body, label, up, color in bodies:
            pb = self._poly_px(pose, body, up)
            pl = self._poly_px(pose, label, up)
            if pb is None or pl is None:
                continue
            cv2.fillPoly(frame, [pb], (58, 62, 66), cv2.LINE_AA, _SHIFT)
            cv2.fillPoly(frame, [pl], LABEL_BGR.get(color, (255, 255, 255)), cv2.LINE_AA, _SHIFT)
        for pos, ground, along, s, bgr in people:
            across = np.array([along[1], -along[0]])
            body = self._poly_px(pose, _ellipse_m(pos, across, 0.24 * s, 0.15 * s, 10), ground + PERSON_CENTRE_HEIGHT_M)
            head = self._poly_px(pose, _ellipse_m(pos, across, 0.11 * s, 0.11 * s, 8), ground + PERSON_HEIGHT_M * s)
            if body is None or head is None:
                continue
            cv2.fillPoly(frame, [body], tuple(float(x) for x in bgr), cv2.LINE_AA, _SHIFT)
            cv2.fillPoly(frame, [head], (30, 38, 52), cv2.LINE_AA, _SHIFT)
        return self._sensor(frame)

    def _sensor(self, frame: np.ndarray) -> np.ndarray:
        rng, h, w = self.rng, frame.shape[0], frame.shape[1]
        if self.noise_sigma > 0:
            b = int(rng.integers(NOISE_BANK))
            y, x = (int(v) for v in rng.integers(0, NOISE_PAD, 2))
            frame = cv2.subtract(cv2.add(frame, self._noise_pos[b, y:y + h, x:x + w]),
                                 self._noise_neg[b, y:y + h, x:x + w])
        q = self.sc.camera.jpeg_quality
        if q > 0:
            ok, buf = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, int(q)])
            if ok:
                frame = cv2.imdecode(buf, cv2.IMREAD_COLOR)
        return frame
