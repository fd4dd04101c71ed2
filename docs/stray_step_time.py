"""Thread time of step 7 of :mod:`uvteam.vision.motion` (a crowd's strays) per frame, on the frame sets of
`uvteam bench vision` (karma.mp4 and AU-AIR; rendered frames skipped), best of three passes. A diagnostic
for docs/performance.md (session 23); not part of the product. Compare two checkouts by running it with
each one's ``shared`` and ``services`` on PYTHONPATH, alternately:

    .venv/bin/python docs/stray_step_time.py
"""

import time

import uvteam.vision.motion as motion
from uvteam_ground import bench_vision as bv


def main() -> None:
    spent: list[int] = []
    step = motion.MotionDetector._with_strays

    def timed(self, *args, **kwargs):
        t0 = time.thread_time_ns()
        out = step(self, *args, **kwargs)
        spent.append(time.thread_time_ns() - t0)
        return out

    motion.MotionDetector._with_strays = timed
    for name, frames, alt_m, dt_s in bv.frame_sets(90):
        if name.startswith("rendered"):
            continue
        h, w = frames[0].shape[:2]
        cfg = bv.uav_motion_config(w, h, alt_m, frame=frames[0])
        best = float("inf")
        for _ in range(3):
            det = motion.MotionDetector(cfg)
            spent.clear()
            for i, f in enumerate(frames):
                det.update(f, i * dt_s)
            best = min(best, sum(spent) / len(frames) / 1e6)
        print(f"{name:30s} step 7: {best:.3f} ms per frame")


if __name__ == "__main__":
    main()
