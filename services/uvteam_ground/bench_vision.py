"""Vision speed on one core (cv2.setNumThreads(1), pinned by `uvteam bench`).

UAV motion detector: real drone frames (../shared/data karma.mp4) resized to 1280x720 and 1920x1080.
HOG people detector: vtest.avi frames resized to 640x480, the tuned settings and OpenCV's defaults.
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np

from uvteam.vision.motion import MotionDetector
from uvteam.vision.people import HogConfig, PeopleDetector

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"


def _frames(path: Path, n: int, size: tuple[int, int]) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    out = []
    while len(out) < n:
        ok, f = cap.read()
        if not ok:
            break
        out.append(cv2.resize(f, size))
    return out


def run() -> dict:
    cv2.setNumThreads(1)
    if not DATA.is_dir():
        print(f"vision: {DATA} not found (the benchmark uses the real clips in ../shared/data)")
        return {}
    res = {}
    for size in ((1280, 720), (1920, 1080)):
        fr = _frames(DATA / "uav_oblique_gopro_karma" / "karma.mp4", 90, size)
        det = MotionDetector()
        det.update(fr[0], 0.0)
        t0 = time.perf_counter()
        for i, f in enumerate(fr[1:], start=1):
            det.update(f, i / 30.0)
        fps = (len(fr) - 1) / (time.perf_counter() - t0)
        res[f"motion_fps_{size[0]}x{size[1]}"] = fps
        print(f"UAV motion detector {size[0]}x{size[1]}: {fps:.1f} fps on one core (target {60 if size[0] == 1280 else 30})")
    res.update(rendered())
    fr = _frames(DATA / "pedestrians_static_opencv" / "vtest.avi", 20, (640, 480))
    for name, cfg in (("tuned", HogConfig()), ("OpenCV default", HogConfig(upscale=1.0, scale_step=1.05, hit_threshold=0.0))):
        d = PeopleDetector(cfg)
        t0 = time.perf_counter()
        for f in fr:
            d.detect(f)
        fps = len(fr) / (time.perf_counter() - t0)
        res[f"hog_fps_{name}"] = fps
        print(f"HOG people detector 640x480, {name}: {fps:.1f} fps on one core (target >= 10)")
    return res


def rendered(n: int = 60) -> dict:
    """The simulator's renderer and the UAV's whole pixel pipeline (colour + motion, as the service
    runs it) on rendered frames of the paper scenarios, at 1280x720 and at 1920x1080 (same field of view)."""
    from dataclasses import replace  # noqa: PLC0415

    from uvteam.vision.uav import UavVision, UavVisionConfig  # noqa: PLC0415
    from uvteam_sim.render import Renderer  # noqa: PLC0415
    from uvteam_sim.scenario import load_scenario  # noqa: PLC0415
    from uvteam_sim.world import SimWorld  # noqa: PLC0415

    scen = DATA.parent / "scenarios"
    res = {}
    for name in ("paper-fig7-alt50", "paper-fig7-alt200"):
        for w, h in ((1280, 720), (1920, 1080)):
            sc = load_scenario(scen / f"{name}.toml")
            sc = replace(sc, camera=replace(sc.camera, width_px=w, height_px=h))
            world = SimWorld(sc, 1)
            r = Renderer(world, np.random.default_rng(1))
            frames, t_render = [], 0.0
            for _ in range(n):
                pose = world.camera_pose()
                t0 = time.perf_counter()
                frames.append(r.render(pose))
                t_render += time.perf_counter() - t0
                for _ in range(4):
                    world.step(0.025)
            vis = UavVision(UavVisionConfig(focal_px=world.camera.focal_px, colours=tuple(sc.ugvs.colors)))
            vis.update(frames[0], 0.0, sc.uav.altitude_agl_m)
            t0 = time.perf_counter()
            for i, f in enumerate(frames[1:], start=1):
                vis.update(f, 0.1 * i, sc.uav.altitude_agl_m)
            fps = (n - 1) / (time.perf_counter() - t0)
            key = f"{name}_{w}x{h}"
            res[f"render_fps_{key}"] = n / t_render
            res[f"uav_pipeline_fps_{key}"] = fps
            print(f"rendered {name} {w}x{h}: renderer {n / t_render:.1f} fps; UAV pipeline (colour + motion, "
                  f"process scale {vis.motion_config.process_scale}) {fps:.1f} fps on one core")
    return res
