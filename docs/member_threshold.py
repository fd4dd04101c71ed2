"""At given times, for every crowd member: the compensated difference round it (5 x 5 pixels at the
detector's processing scale, the pixel that passes best), the motion threshold there, the ground's 3 x 3
range, and whether step 3 of :mod:`uvteam.vision.motion` kept any pixel there as moving. Why walkers are
not seen, in grey levels. A diagnostic for docs/results-worlds.md (session 23); not part of the product.

    .venv/bin/python docs/member_threshold.py scenarios/real-alt120-lm6.toml 9 4.5
"""

import sys

import cv2
import numpy as np

import uvteam.vision.motion as motion
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam


def main(path: str, seed: int, times_s: list[float]) -> None:
    team = SimTeam(load_scenario(path), seed, "pixels")
    world = team.sim.world
    first: list[float] = []
    frame: dict = {}
    update, moving, render = motion.MotionDetector.update, motion.MotionDetector._moving, team.renderer.render

    def on_render(pose):       # the pose the frame was drawn with
        frame["pose"] = pose
        return render(pose)

    def on_update(det, img, stamp_s, *args, **kwargs):
        first[:] = first or [stamp_s]
        frame["t"] = stamp_s - first[0]
        return update(det, img, stamp_s, *args, **kwargs)

    def on_moving(det, prev, curr, M, warp):
        out = moving(det, prev, curr, M, warp)
        if not any(abs(frame["t"] - t) < 0.05 for t in times_s):
            return out
        cfg = det.cfg
        warped = warp(prev, cv2.INTER_LINEAR, 0)
        diff = cv2.absdiff(curr, warped)
        g = cv2.min(motion._local_range(curr), motion._local_range(warped))
        noise = motion._robust_sigma(diff, np.full(diff.shape, 255, np.uint8))
        floor = max(cfg.diff_floor, cfg.noise_k * noise)
        limit = cv2.min(cv2.convertScaleAbs(g, alpha=cfg.gradient_gain, beta=floor), int(cfg.diff_threshold))
        s = cfg.process_scale
        print(f"t {frame['t']:.1f} s: noise {noise:.2f}, floor {floor:.1f}, gradient gain {cfg.gradient_gain}, "
              f"cap {cfg.diff_threshold} (grey levels)")
        for k, full_px in enumerate(world.crowd_groups_px(frame["pose"])):
            print(f"  crowd {k}")
            for x, y in (full_px + 0.5) * s - 0.5:
                xi, yi = int(round(x)), int(round(y))
                if not (0 <= xi < diff.shape[1] and 0 <= yi < diff.shape[0]):
                    continue
                win = (slice(max(yi - 2, 0), yi + 3), slice(max(xi - 2, 0), xi + 3))
                d, lim = diff[win].astype(int), limit[win].astype(int)
                j = np.unravel_index(np.argmax(d - lim), d.shape)
                print(f"    member at ({xi}, {yi}) px: difference {d[j]} against threshold {lim[j]} "
                      f"(range {g[win][j]}), moving {'yes' if out[win].any() else 'no'}")
        return out

    team.renderer.render = on_render
    motion.MotionDetector.update = on_update
    motion.MotionDetector._moving = on_moving
    team.run(max(times_s) + 0.2)


if __name__ == "__main__":
    if len(sys.argv) < 4:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), [float(t) for t in sys.argv[3:]])
