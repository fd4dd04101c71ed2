"""Benchmark (`uvteam bench render`): the simulator's renderer and the UAV's whole pixel pipeline on rendered
frames, one core. Registered in the ``uvteam.benchmarks`` entry-point group, so `uvteam bench` finds it
without importing the simulator by name; :func:`frames` is registered in ``uvteam.bench_frames``, so the
vision benchmark runs the motion detector against its yardsticks on rendered frames too."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from uvteam.errors import ConfigError
from uvteam.io.files import ground_imagery_files, load_scenario
from uvteam.vision.uav import UavVision, UavVisionConfig

from .render import Renderer
from .world import SimWorld

SCENARIOS = Path(__file__).resolve().parents[2].parent / "shared" / "scenarios"
NAMES = ("paper-fig7-alt50", "paper-fig7-alt200")
# a world of real aerial imagery at 120 m, which the UAV pipeline processes at full resolution (a
# walker is under 3 px at half): the deployed case the paper scenarios' frames do not show
WORLDS = (Path(__file__).resolve().parents[2] / "scenarios" / "real-alt120-lm6.toml",)
STEP_S, STEPS_PER_FRAME = 0.025, 4   # 10 frames a second, the world stepped as the simulator steps it


def render(name: str | Path, n: int, size: tuple[int, int]):
    """``n`` frames of a paper scenario (its name), or of a scenario file, at ``size`` (same field of
    view): (frames, world, scenario, render s)."""
    sc = load_scenario(name if isinstance(name, Path) else SCENARIOS / f"{name}.toml")
    sc = replace(sc, camera=replace(sc.camera, width_px=size[0], height_px=size[1]))
    world = SimWorld(sc, 1)
    r = Renderer(world, np.random.default_rng(1))
    out, t_render = [], 0.0
    for _ in range(n):
        pose = world.camera_pose()
        t0 = time.perf_counter()
        out.append(r.render(pose))
        t_render += time.perf_counter() - t0
        for _ in range(STEPS_PER_FRAME):
            world.step(STEP_S)
    return out, world, sc, t_render


def frames(n: int = 60, sizes: tuple[tuple[int, int], ...] = ((1280, 720),)) -> list:
    """(name, frames, height above ground m, frame interval s) per paper scenario and size; [] without
    the scenarios."""
    if not SCENARIOS.is_dir():
        print(f"render: {SCENARIOS} not found: rendered frames skipped")
        return []
    out = []
    for name in NAMES + _worlds():
        for size in sizes:
            fr, _, sc, _ = render(name, n, size)
            out.append((f"rendered {_name(name)} {size[0]}x{size[1]}", fr, sc.uav.altitude_agl_m,
                        STEP_S * STEPS_PER_FRAME))
    return out


def _name(name: str | Path) -> str:
    return name.stem if isinstance(name, Path) else name


def _worlds() -> tuple[Path, ...]:
    """``WORLDS`` whose ground imagery is here (../shared/data), with a word for those skipped."""
    out = []
    for path in WORLDS:
        try:
            ground_imagery_files(load_scenario(path))
            out.append(path)
        except ConfigError as e:
            print(f"render: {path.name} skipped: {e}")
    return tuple(out)


def run(n: int = 60) -> dict:
    """The simulator's renderer and the UAV's whole pixel pipeline (color + motion, as the service
    runs it) on rendered frames of the paper scenarios and of ``WORLDS``, at 1280x720 and at 1920x1080
    (same field of view)."""
    cv2.setNumThreads(1)
    if not SCENARIOS.is_dir():
        print(f"render: {SCENARIOS} not found (the benchmark renders the paper scenarios)")
        return {}
    res = {}
    for name in NAMES + _worlds():
        for w, h in ((1280, 720), (1920, 1080)):
            fr, world, sc, t_render = render(name, n, (w, h))
            vis = UavVision(UavVisionConfig(focal_px=world.camera.focal_px, colors=tuple(sc.ugvs.colors)))
            vis.update(fr[0], 0.0, sc.uav.altitude_agl_m)
            t0 = time.perf_counter()
            for i, f in enumerate(fr[1:], start=1):
                vis.update(f, 0.1 * i, sc.uav.altitude_agl_m)
            fps = (n - 1) / (time.perf_counter() - t0)
            key = f"{_name(name)}_{w}x{h}"
            res[f"render_fps_{key}"] = n / t_render
            res[f"uav_pipeline_fps_{key}"] = fps
            print(f"rendered {_name(name)} {w}x{h}: renderer {n / t_render:.1f} fps; UAV pipeline (color + motion, "
                  f"process scale {vis.motion_config.process_scale}) {fps:.1f} fps on one core")
    return res
