"""Benchmark (`uvteam bench render`): the simulator's renderer and the UAV's whole pixel pipeline on rendered
frames, one core. Registered in the ``uvteam.benchmarks`` entry-point group, so `uvteam bench` finds it
without importing the simulator by name."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from uvteam.io.files import load_scenario
from uvteam.vision.uav import UavVision, UavVisionConfig

from .render import Renderer
from .world import SimWorld

SCENARIOS = Path(__file__).resolve().parents[2].parent / "shared" / "scenarios"


def run(n: int = 60) -> dict:
    cv2.setNumThreads(1)
    """The simulator's renderer and the UAV's whole pixel pipeline (color + motion, as the service
    runs it) on rendered frames of the paper scenarios, at 1280x720 and at 1920x1080 (same field of view)."""
    scen = SCENARIOS
    if not scen.is_dir():
        print(f"render: {scen} not found (the benchmark renders the paper scenarios)")
        return {}
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
            vis = UavVision(UavVisionConfig(focal_px=world.camera.focal_px, colors=tuple(sc.ugvs.colors)))
            vis.update(frames[0], 0.0, sc.uav.altitude_agl_m)
            t0 = time.perf_counter()
            for i, f in enumerate(frames[1:], start=1):
                vis.update(f, 0.1 * i, sc.uav.altitude_agl_m)
            fps = (n - 1) / (time.perf_counter() - t0)
            key = f"{name}_{w}x{h}"
            res[f"render_fps_{key}"] = n / t_render
            res[f"uav_pipeline_fps_{key}"] = fps
            print(f"rendered {name} {w}x{h}: renderer {n / t_render:.1f} fps; UAV pipeline (color + motion, "
                  f"process scale {vis.motion_config.process_scale}) {fps:.1f} fps on one core")
    return res
