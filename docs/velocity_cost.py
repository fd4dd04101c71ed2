"""The CPU cost of motion step 8 (a crowd blob's walkers' velocity, `uvteam.vision.blob_velocity`): the UAV pipeline's
motion detector as it configures it, with and without that step, interleaved frame by frame on one core (each
frame's least CPU time over three passes), on karma.mp4 1280x720 and the rendered frames of `uvteam bench vision`.
A measurement for docs/performance.md (session 51); not part of the product.

    .venv/bin/python docs/velocity_cost.py
"""
import time
from dataclasses import replace
from importlib.metadata import entry_points
import cv2
import numpy as np
from uvteam.vision.motion import MotionDetector
from uvteam_ground.bench_vision import KARMA, KARMA_ALT_M, _video, uav_motion_config

cv2.setNumThreads(1)
sets = [("karma.mp4 1280x720", _video(KARMA, 90, (1280, 720)), KARMA_ALT_M, 1 / 29.97)]
for ep in entry_points(group="uvteam.bench_frames"):
    for name, frames, alt_m, dt_s in ep.load()(n=60):
        sets.append((name, frames, alt_m, dt_s))
for name, frames, alt_m, dt_s in sets:
    h, w = frames[0].shape[:2]
    cfg = uav_motion_config(w, h, alt_m, frame=frames[0])
    best = {"with": [], "without": []}
    for p in range(3):
        dets = {"with": MotionDetector(cfg), "without": MotionDetector(replace(cfg, velocity_lag_s=0.0))}
        times = {k: [] for k in dets}
        order = ["with", "without"]
        for i, f in enumerate(frames):
            for k in (order if i % 2 == 0 else order[::-1]):
                t0 = time.thread_time()
                dets[k].update(f, i * dt_s)
                times[k].append(time.thread_time() - t0)
        for k in dets:
            best[k].append(times[k])
    w_ = np.min(np.array(best["with"]), 0).sum(); wo = np.min(np.array(best["without"]), 0).sum()
    print(f"{name:45s} lag {cfg.velocity_lag_s:.2f} s: with step 8 {len(frames)/w_:6.1f} fps, without {len(frames)/wo:6.1f} fps, "
          f"cost {100 * (w_ / wo - 1):+.0f} %")
