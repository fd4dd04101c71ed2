"""Rendered frames through the UAV's pixel pipeline, as a drop-in for the sensor model in experiments.

``pixel_detector()`` returns ``detector(world, pose, stamp_s) -> SensorFrame``: it renders the frame
(:mod:`.render`) and runs the same :class:`uvteam.vision.uav.UavVision` the UAV service runs. The
renderer has its own random stream (seeded from the world's seed), so switching detectors does not
change the world's own draws. ``blob_kind`` labels each blob with the nearest true object, only for
diagnostics; nothing downstream reads it.
"""

from __future__ import annotations

import numpy as np

from uvteam.camera import CameraPose, project
from uvteam.vision.uav import UavVision, UavVisionConfig

from .render import Renderer
from .world import SensorFrame, SimWorld

__all__ = ["PixelDetector", "pixel_detector"]

KIND_GATE_PX = 30.0


class PixelDetector:
    kind = "pixels"

    def __init__(self, keep_frames: bool = False, **vision_overrides) -> None:
        self.vision_overrides = vision_overrides   # UavVisionConfig fields, for ablations
        self._world: SimWorld | None = None
        self.renderer: Renderer | None = None
        self.vision: UavVision | None = None
        self.keep_frames = keep_frames
        self.last_frame: np.ndarray | None = None
        self.last_result = None

    def _start(self, world: SimWorld) -> None:
        sc = world.sc
        self._world = world
        self.renderer = Renderer(world, np.random.default_rng([world.seed, 0x5EE]))
        self.vision = UavVision(UavVisionConfig(focal_px=world.camera.focal_px, colors=tuple(sc.ugvs.colors),
                                                label_side_m=sc.ugvs.label_side_m, **self.vision_overrides))

    def __call__(self, world: SimWorld, pose: CameraPose, stamp_s: float) -> SensorFrame:
        if world is not self._world:
            self._start(world)
        frame = self.renderer.render(pose)
        if self.keep_frames:
            self.last_frame = frame
        alt_agl_m = pose.up_m - float(world.terrain_up_m(np.array([pose.east_m, pose.north_m]))[0])
        r = self.last_result = self.vision.update(frame, stamp_s, alt_agl_m)
        return SensorFrame(stamp_s, dict(r.landmarks_px), r.blobs.xy_px, r.blobs.xyxy_px,
                           blob_kinds(world, pose, r.blobs.xy_px), r.blob_color, r.blobs.area_px)


def blob_kinds(world: SimWorld, pose: CameraPose, xy_px: np.ndarray) -> tuple[str, ...]:
    if not len(xy_px):
        return ()
    names, pts = [], []
    lm = project(world.camera, pose, world.ugv_label_enu())
    for color, p in zip(world.sc.ugvs.colors, lm):
        names.append(f"ugv:{color}")
        pts.append(p)
    for k, px in enumerate(world.crowd_groups_px(pose)):
        names.append(f"crowd:{k}")
        pts.append(np.nanmean(px, 0))
    pts = np.array(pts)
    d = np.sqrt(((xy_px[:, None] - pts[None]) ** 2).sum(-1))
    d[~np.isfinite(d)] = np.inf
    j = d.argmin(1)
    return tuple(names[jj] if d[i, jj] <= KIND_GATE_PX else "false" for i, jj in enumerate(j))


def pixel_detector(keep_frames: bool = False, **vision_overrides) -> PixelDetector:
    return PixelDetector(keep_frames, **vision_overrides)
