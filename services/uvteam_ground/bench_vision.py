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

