"""Rendering the UAV's camera frames from the world: pure functions of the world state, pose and a seeded RNG.

What a frame holds, and how it is made (every number here is a modelling choice, stated once):

- **Ground** (``[ground]``), a texture in ground metres (north up) of ``texel_m`` per texel (default:
  one texel per nadir image pixel), made once per run:
  - ``procedural`` (the default): a desert generated from the seed: four octaves of value noise (40,
    10, 3 and 0.8 m) in sand colors, plus shrubs (dusty grey-olive discs, 0.3-1.2 m) and pale rocks,
    which give goodFeaturesToTrack its corners. Saturation stays under 100 (OpenCV scale), below
    every roof-label range even with the sensor noise, so this ground never looks like a landmark;
  - ``imagery``: a mosaic of real aerial frames (``[[ground.imagery]]``, each with its own ground
    sample distance ``gsd_m``): every frame is area-averaged to the texel size once (so a car of
    4.5 m stays 4.5 m), then the ground is covered with square pieces of ``tile_m`` cut at random
    from frames drawn in proportion to their ground area, turned by a random multiple of 90 deg and
    mirrored at random, on a grid with a random origin; neighbouring pieces overlap by a tenth of a
    piece and are cross-faded there. Whatever the frames hold (roads, markings, parked cars, people,
    grass, red doors) is static.
- **Projection**: every image pixel is cast as a ray from the camera pose (altitude, hover wobble,
  gimbal roll/pitch) onto the terrain (``SimWorld.terrain_up_m``; three fixed-point steps, exact on a
  flat plane); this is done on a grid every 8 pixels and interpolated bilinearly (the terrain is
  smooth at that scale), then the texture is sampled with ``cv2.remap``. A fixed gimbal tilt
  (``uav.tilt_roll_deg``/``tilt_pitch_deg``) and the run's unreported residual (``uav.attitude_sigma_deg``)
  are part of the pose, like the jitter.
- **Lens** (``[lens]``): with the prefilter on (``prefilter = "mipmap"``, and by default whenever the
  ground is not the default procedural one) the texture is area-averaged to each pixel's footprint,
  as a lens and sensor integrate light over a pixel: a Gaussian pyramid (``cv2.pyrDown``) of the
  texture, each pixel's level from the larger of its two texel-per-pixel rates (log2), sampled
  bilinearly in the two levels around it and blended linearly between them (trilinear mip-mapping),
  so a texel smaller than a pixel (off nadir, tilted, or a fine ``texel_m``) does not alias. Off (the
  default for the procedural ground) it is sampled as it always was: one bilinear tap per pixel.
  ``blur_sigma_px`` then blurs the whole image (ground and objects) with a Gaussian, before the noise.
- **Objects**, drawn in ground coordinates and projected at their height as sub-pixel polygons, each
  pixel taking the share of its area a polygon covers (counted on a 16 x 16 grid in the pixel, as a
  lens integrates light; ``lens.objects = "area"``, the default). OpenCV's own anti-aliased fill
  (``"opencv"``, which drew every frame of ../shared/scenarios until 2026-12-04 and reproduces them bit
  for bit) makes still edges flicker under sub-pixel wobble (``_fill``): shadows first (of walkers, UGVs and distractors; sun at 55 deg elevation from the
  south-east, shadows darken the ground to 55 %), then the distractors (``uvteam_sim.world``:
  painted squares; parked vehicles and flat-roofed sheds drawn as their walls, the convex hull of
  base and top at 70 % of the top's grey, then their top, then the label-coloured patch of
  ``label_side_m`` on it), then UGVs (a dark body ``length_m`` x ``width_m`` along the heading,
  with the square roof label of ``label_side_m`` in the UGV's color at roof height, unless
  ``ugvs.roof_labels`` is false), then people
  (an ellipse 0.48 x 0.30 m of muted clothing across the direction of travel, a 0.22 m head, at
  1.0 m height, sizes varying +-10 %).
- **Sensor**: additive Gaussian noise ``noise_sigma`` per channel (drawn from a bank made once from
  the seed, picked at a random offset each frame), then JPEG at ``jpeg_quality`` when it is > 0.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from uvteam.camera import CameraPose, R_cam_from_enu, project
from uvteam.errors import ConfigError
from uvteam.io.files import ground_imagery_files
from uvteam.scenario import off_nadir_deg

from .world import DISTRACTOR_SHAPES, PERSON_CENTRE_HEIGHT_M, ROOF_HEIGHT_M, Distractor, SimWorld

__all__ = ["Renderer", "LABEL_BGR", "make_ground_texture", "make_imagery_texture", "mip_pyramid", "sample_prefiltered"]

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
COVERAGE_SS = 16                  # objects: a pixel's share of a polygon counted on a 16 x 16 grid in it
COVERAGE_MAX_PX = 4_000_000       # ... a polygon's box on that grid at most this big (a coarser grid past it)
MAX_TEXTURE_BYTES = 256 * 2 ** 20  # a run's ground texture (its mip levels add a third; the procedural one is made in float32)
TILE_OVERLAP = 0.1                 # imagery mosaic: neighbouring pieces overlap by this fraction and cross-fade
MAX_MIP_LEVELS = 8
LOD_GRID_PX = 8                    # mip level measured every this many pixels, interpolated between
WALL_GAIN = 0.7                    # a distractor's walls against its top
HALF_DIAGONAL_MARGIN = 1.25        # the ground kept around the crowds' paths: this many half footprints, + 30 m


def _value_noise(rng: np.random.Generator, shape: tuple[int, int], cell_px: float) -> np.ndarray:
    """Smooth noise, unit variance-ish, with features about ``cell_px`` texels across."""
    h, w = shape
    gh, gw = max(2, int(math.ceil(h / cell_px)) + 2), max(2, int(math.ceil(w / cell_px)) + 2)
    g = rng.standard_normal((gh, gw)).astype(np.float32)
    up = cv2.resize(g, (int(gw * cell_px), int(gh * cell_px)), interpolation=cv2.INTER_CUBIC)
    return up[:h, :w]


def _fill(img: np.ndarray, poly: np.ndarray, value) -> None:
    """Fill a polygon (int32 vertices in 1/16 px, pixel centres on integers) into ``img`` in place, each
    pixel blended by the share of its area the polygon covers, as a lens and sensor integrate light.
    OpenCV's anti-aliased fill is not that: a pixel on an edge or a corner jumps by up to three quarters
    of the contrast when the polygon moves by 1/32 px, so a still object under hover wobble flickers at
    its edges, which a motion detector rightly takes for motion (a diamond moved in 1/32 px steps: 188
    of 255 grey levels at most; counted on the 16 x 16 grid, 30 for a 1/64 px step). OpenCV fills the
    grid cells an edge runs through on the polygon's right and lower side too: objects are up to 1/16
    px bigger there, the same in every frame."""
    p = poly.reshape(-1, 2).astype(np.float64) / _ONE
    h, w = img.shape[:2]
    x0, y0 = max(int(np.floor(p[:, 0].min())) - 1, 0), max(int(np.floor(p[:, 1].min())) - 1, 0)
    x1, y1 = min(int(np.ceil(p[:, 0].max())) + 2, w), min(int(np.ceil(p[:, 1].max())) + 2, h)
    if x1 <= x0 or y1 <= y0:
        return
    ss = COVERAGE_SS
    while ss > 1 and (x1 - x0) * (y1 - y0) * ss * ss > COVERAGE_MAX_PX:
        ss //= 2
    # pixel (x, y) covers [x - 0.5, x + 0.5); on the fine grid its ss x ss cells' centres
    fine = np.rint(((p - (x0, y0) + 0.5) * ss - 0.5) * _ONE).astype(np.int32)
    mask = np.zeros(((y1 - y0) * ss, (x1 - x0) * ss), np.uint8)
    cv2.fillPoly(mask, [fine], 255, cv2.LINE_8, _SHIFT)
    a = cv2.resize(mask, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA).astype(np.float32) * (1.0 / 255.0)
    roi = img[y0:y1, x0:x1]
    paint = np.empty_like(roi)
    paint[...] = value
    roi[...] = cv2.blendLinear(roi, paint, 1.0 - a, a)


def _fill_opencv(img: np.ndarray, poly: np.ndarray, value) -> None:
    """OpenCV's anti-aliased fill, as objects were drawn before ``_fill``: ``lens.objects = "opencv"``
    (the frames of ../shared/scenarios as drawn until 2026-12-04)."""
    cv2.fillPoly(img, [poly], value, cv2.LINE_AA, _SHIFT)


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


def make_imagery_texture(rng: np.random.Generator, size_px: tuple[int, int], texel_m: float,
                         images: list[tuple[np.ndarray, float, str]], tile_m: float) -> np.ndarray:
    """A ground texture (BGR uint8), ``size_px`` = (rows, cols) at ``texel_m``, mosaicked from real aerial
    frames ``(image_bgr, gsd_m, name)``; see the module docstring. ValueError naming the frame when a
    piece of ``tile_m`` does not fit in it."""
    h, w = size_px
    t = max(2, int(round(tile_m / texel_m)))          # a piece's side in texels, overlap excluded
    ov = max(1, int(round(TILE_OVERLAP * t)))
    side = t + ov
    scaled = []
    for img, gsd_m, name in images:
        s = gsd_m / texel_m
        size = (max(1, int(round(img.shape[1] * s))), max(1, int(round(img.shape[0] * s))))
        im = cv2.resize(img, size, interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_CUBIC)
        if min(im.shape[:2]) < side:
            raise ValueError(f"{name}: {img.shape[1]}x{img.shape[0]} px at {gsd_m} m/px is "
                             f"{img.shape[1] * gsd_m:.1f} x {img.shape[0] * gsd_m:.1f} m, smaller than a piece of "
                             f"{tile_m * (1 + TILE_OVERLAP):.1f} m (tile_m plus the overlap)")
        scaled.append(im)
    area = np.array([im.shape[0] * im.shape[1] for im in scaled], float)
    prob = area / area.sum()                        # every square metre of imagery equally likely
    tex = np.zeros((h, w, 3), np.uint8)
    ramp = np.minimum(np.arange(side, dtype=np.float32) / ov, 1.0)   # 0 at a piece's top/left edge -> 1
    oy, ox = (int(v) for v in rng.integers(0, t, 2))
    for y0 in range(oy - t, h, t):
        for x0 in range(ox - t, w, t):
            im = scaled[int(rng.choice(len(scaled), p=prob))]
            cy = int(rng.integers(0, im.shape[0] - side + 1))
            cx = int(rng.integers(0, im.shape[1] - side + 1))
            piece = np.rot90(im[cy:cy + side, cx:cx + side], int(rng.integers(4)))
            if rng.random() < 0.5:
                piece = piece[:, ::-1]
            ya, xa = y0 - ov, x0 - ov                      # the piece's top-left, overlapping what is there
            ys, xs = max(ya, 0), max(xa, 0)
            ye, xe = min(ya + side, h), min(xa + side, w)
            if ye <= ys or xe <= xs:
                continue
            p = piece[ys - ya:ye - ya, xs - xa:xe - xa].astype(np.float32)
            ry = ramp[ys - ya:ye - ya] if ya > oy - t - ov else np.ones(ye - ys, np.float32)
            rx = ramp[xs - xa:xe - xa] if xa > ox - t - ov else np.ones(xe - xs, np.float32)
            a = (ry[:, None] * rx[None, :])[..., None]
            old = tex[ys:ye, xs:xe].astype(np.float32)
            tex[ys:ye, xs:xe] = np.clip(np.rint(old + a * (p - old)), 0, 255).astype(np.uint8)
    return tex


def mip_pyramid(texture: np.ndarray, levels: int = MAX_MIP_LEVELS) -> list[np.ndarray]:
    """The texture and its Gaussian-prefiltered halvings (level k: 2^k texels per texel)."""
    pyr = [texture]
    while len(pyr) < levels and min(pyr[-1].shape[:2]) >= 4:
        pyr.append(cv2.pyrDown(pyr[-1]))
    return pyr


def sample_prefiltered(pyr: list[np.ndarray], mx: np.ndarray, my: np.ndarray) -> np.ndarray:
    """Trilinear mip-mapping: each pixel of the level-0 texture maps ``mx, my`` sampled at the pyramid
    level of its footprint (log2 of the larger texel-per-pixel rate along the image axes), blended
    between the two levels around it. A footprint under one texel samples level 0 bilinearly."""
    g = LOD_GRID_PX   # the footprint varies smoothly: measured on a grid, then interpolated
    cx, cy = mx[::g, ::g], my[::g, ::g]
    fx = np.hypot(np.diff(cx, axis=1), np.diff(cy, axis=1))[:-1, :] / g
    fy = np.hypot(np.diff(cx, axis=0), np.diff(cy, axis=0))[:, :-1] / g
    lod = np.log2(np.maximum(np.maximum(fx, fy), 1.0)).astype(np.float32)
    lod = cv2.resize(lod, (mx.shape[1], mx.shape[0]), interpolation=cv2.INTER_LINEAR)
    lod = np.clip(lod, 0.0, len(pyr) - 1.0).astype(np.float32)
    lo, hi = int(np.floor(lod.min())), int(np.ceil(lod.max()))
    if hi == 0:
        return cv2.remap(pyr[0], mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
    acc = np.zeros(mx.shape + (3,), np.float32)
    for k in range(lo, hi + 1):
        wk = np.maximum(0.0, 1.0 - np.abs(lod - k))
        if not wk.any():
            continue
        s = 1.0 / (1 << k)     # cv2.pyrDown keeps every other texel: level k's texel i sits on level 0's 2^k i
        img = cv2.remap(pyr[k], mx * s, my * s, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
        acc += wk[..., None] * img
    return np.clip(np.rint(acc), 0, 255).astype(np.uint8)


def _ellipse_m(centre, along, half_a_m: float, half_b_m: float, n: int = 12) -> np.ndarray:
    """(n, 2) ground points of an ellipse with semi-axis ``half_a_m`` along unit vector ``along``."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    u = np.asarray(along, float)
    v = np.array([-u[1], u[0]])
    return centre + np.outer(half_a_m * np.cos(t), u) + np.outer(half_b_m * np.sin(t), v)


def _read_imagery(sc) -> list[tuple[np.ndarray, float, str]]:
    """Every ``[[ground.imagery]]`` frame, decoded, with its ground sample distance; ConfigError naming
    the source when a file does not decode or is too small for a piece of ``tile_m``."""
    out = []
    for i, (src, files) in enumerate(zip(sc.ground.imagery, ground_imagery_files(sc))):
        for f in files:
            img = cv2.imread(str(f), cv2.IMREAD_COLOR)
            if img is None:
                raise ConfigError(sc.path, f"ground.imagery[{i}].path", f"{f}: not a decodable image")
            side_m = min(img.shape[:2]) * src.gsd_m
            if side_m < sc.ground.tile_m * (1 + TILE_OVERLAP):
                raise ConfigError(sc.path, "ground.tile_m",
                                  f"{sc.ground.tile_m:g} m pieces (plus {TILE_OVERLAP:.0%} overlap) do not fit in "
                                  f"{Path(f).name}, {side_m:.1f} m on its short side at ground.imagery[{i}].gsd_m")
            out.append((img, src.gsd_m, Path(f).name))
    return out


class Renderer:
    """Draws the UAV camera frame (BGR uint8, camera size) for a world. One per run."""

    def __init__(self, world: SimWorld, rng: np.random.Generator) -> None:
        sc = world.sc
        self.world, self.rng, self.sc = world, rng, sc
        cam = world.camera
        self.gsd_m = sc.uav.altitude_agl_m / cam.focal_px
        self.texel_m = sc.ground.texel_m if sc.ground.texel_m > 0 else self.gsd_m
        # the ground the camera can see during the run: every crowd's path, the UAV's lag, the footprint,
        # and with a fixed tilt how far the view's far corner moves out (nothing added without one)
        fw, fh = cam.footprint_m(sc.uav.altitude_agl_m)
        margin = max(fw, fh) / 2 * HALF_DIAGONAL_MARGIN + 30.0
        tilt_deg = off_nadir_deg(*world.fixed_tilt_deg())
        if tilt_deg > 0:
            corner = math.atan(math.hypot(cam.width_px, cam.height_px) / 2 / cam.focal_px)
            margin += sc.uav.altitude_agl_m * (math.tan(corner + math.radians(tilt_deg)) - math.tan(corner))
        pts = [world.crowd_c, world.crowd_c + world.crowd_v * sc.run.duration_s]
        lo = np.min(np.vstack(pts), 0) - margin
        hi = np.max(np.vstack(pts), 0) + margin
        self.west_m, self.north_top_m = float(lo[0]), float(hi[1])
        cols = int(math.ceil((hi[0] - lo[0]) / self.texel_m))
        rows = int(math.ceil((hi[1] - lo[1]) / self.texel_m))
        if rows * cols * 3 > MAX_TEXTURE_BYTES:
            raise ConfigError(sc.path, "ground.texel_m",
                              f"a ground texture of {cols} x {rows} texels at {self.texel_m:.3f} m would take "
                              f"{rows * cols * 3 / 2 ** 20:.0f} MB (at most {MAX_TEXTURE_BYTES / 2 ** 20:.0f}): "
                              "use coarser texels or a shorter run")
        if sc.ground.texture == "imagery":
            self.texture = make_imagery_texture(rng, (rows, cols), self.texel_m, _read_imagery(sc), sc.ground.tile_m)
        else:
            self.texture = make_ground_texture(rng, (rows, cols), self.texel_m)
        self.mip = mip_pyramid(self.texture) if sc.lens.mipmap(sc.ground) else None
        self.fill = _fill if sc.lens.area_fill else _fill_opencv
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
        if self.mip is None:
            frame = cv2.remap(self.texture, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
        else:
            frame = sample_prefiltered(self.mip, mx, my)
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
                    self.fill(shade, poly, gain)
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
                self.fill(shade, poly, gain)
            lab = sc.ugvs.label_side_m / 2
            label = np.array([fwd * a * lab + side * b * lab for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1))])
            bodies.append((world.ugv_p[i] + corners, world.ugv_p[i] + label, ugv_up[i] + ROOF_HEIGHT_M, color))
        things = [self._distractor_polys(pose, d) for d in world.distractors]
        for th in things:
            if th is not None and th[0] is not None:
                self.fill(shade, th[0], gain)
        frame = cv2.multiply(frame, cv2.merge([shade, shade, shade]), scale=1.0 / 255.0)
        for th in things:
            if th is not None:
                for poly, bgr in th[1]:
                    self.fill(frame, poly, bgr)
        for body, label, up, color in bodies:
            pb = self._poly_px(pose, body, up)
            pl = self._poly_px(pose, label, up)
            if pb is None or pl is None:
                continue
            self.fill(frame, pb, (58, 62, 66))
            if sc.ugvs.roof_labels:
                self.fill(frame, pl, LABEL_BGR.get(color, (255, 255, 255)))
        for pos, ground, along, s, bgr in people:
            across = np.array([along[1], -along[0]])
            body = self._poly_px(pose, _ellipse_m(pos, across, 0.24 * s, 0.15 * s, 10), ground + PERSON_CENTRE_HEIGHT_M)
            head = self._poly_px(pose, _ellipse_m(pos, across, 0.11 * s, 0.11 * s, 8), ground + PERSON_HEIGHT_M * s)
            if body is None or head is None:
                continue
            self.fill(frame, body, tuple(float(x) for x in bgr))
            self.fill(frame, head, (30, 38, 52))
        if sc.lens.blur_sigma_px > 0:
            frame = cv2.GaussianBlur(frame, (0, 0), sc.lens.blur_sigma_px)
        return self._sensor(frame)

    def _distractor_polys(self, pose: CameraPose, d: Distractor):
        """(shadow polygon or None, [(polygon, BGR), ...] to fill in order) in pixels, or None when behind."""
        shape = DISTRACTOR_SHAPES[d.kind]
        hd = math.radians(d.heading_deg)
        fwd = np.array([math.sin(hd), math.cos(hd)])
        side = np.array([fwd[1], -fwd[0]])
        pos = np.array([d.east_m, d.north_m])
        ground = float(self.world.terrain_up_m(pos)[0])
        square = ((1, 1), (1, -1), (-1, -1), (-1, 1))
        lab = self.sc.ugvs.label_side_m / 2
        patch = pos + np.array([fwd * a * lab + side * b * lab for a, b in square])
        paint = tuple(float(c) * d.paint_gain for c in LABEL_BGR.get(d.color, (255, 255, 255)))
        top_up = ground + shape.height_m
        pp = self._poly_px(pose, patch, top_up)
        if pp is None:
            return None
        if shape.length_m <= 0:
            return None, [(pp, paint)]
        foot = np.array([fwd * a * shape.length_m / 2 + side * b * shape.width_m / 2 for a, b in square])
        sh = shape.height_m * self.shadow_per_m * self.shadow_dir
        shadow = cv2.convexHull(np.vstack([foot, foot + sh]).astype(np.float32)).reshape(-1, 2)
        ps = self._poly_px(pose, pos + shadow, ground)
        base = project(self.world.camera, pose, np.column_stack([pos + foot, np.full(4, ground)]))
        top = project(self.world.camera, pose, np.column_stack([pos + foot, np.full(4, top_up)]))
        if not (np.isfinite(base).all() and np.isfinite(top).all()):
            return None
        walls = np.rint(cv2.convexHull(np.vstack([base, top]).astype(np.float32)).reshape(-1, 2) * _ONE).astype(np.int32)
        pt = np.rint(top * _ONE).astype(np.int32)
        g = d.body_grey
        return ps, [(walls, (g * WALL_GAIN,) * 3), (pt, (g,) * 3), (pp, paint)]

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
