"""Thread time of the UAV's motion detector per frame with the 3 x 3 box test (as shipped) and without it
(``box_k`` 0), alternated frame by frame on the same karma.mp4 frames in one process, best of 3 passes, one
core (docs/results-worlds.md and docs/performance.md, session 26). A measurement, not a project benchmark:
`uvteam bench vision` is the benchmark against the plain pipeline.

    taskset -c 1 .venv/bin/python docs/box_test_time.py
"""

import time
from dataclasses import replace

import cv2
import numpy as np

from uvteam.vision.motion import MotionDetector
from uvteam_ground.bench_vision import KARMA, KARMA_ALT_M, _video, uav_motion_config

FRAMES = 90
PASSES = 3


def main() -> None:
    cv2.setNumThreads(1)
    for size in ((1280, 720), (1920, 1080)):
        frames = _video(KARMA, FRAMES, size)
        shipped = uav_motion_config(*size, KARMA_ALT_M, frame=frames[0])
        cfgs = {"box": shipped, "without": replace(shipped, box_k=0.0)}
        n = len(frames) - 1
        best = {k: np.full(n, np.inf) for k in cfgs}
        for p in range(PASSES):
            dets = {k: MotionDetector(c) for k, c in cfgs.items()}
            for d in dets.values():
                d.update(frames[0], 0.0)
            for i in range(1, len(frames)):
                for k in (list(dets) if (i + p) % 2 == 0 else list(dets)[::-1]):
                    c0 = time.thread_time()
                    dets[k].update(frames[i], i / 30)
                    best[k][i - 1] = min(best[k][i - 1], time.thread_time() - c0)
        b, o = (1e3 * best[k].sum() / n for k in ("box", "without"))
        print(f"karma.mp4 {size[0]}x{size[1]}, box_k {shipped.box_k}: {b:.2f} ms a frame, without {o:.2f} ms: "
              f"+{b - o:.2f} ms ({100 * (b / o - 1):.0f} %)")


if __name__ == "__main__":
    main()
