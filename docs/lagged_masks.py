"""How many of a crowd's walkers step 3 of the motion detector marks as moving when this frame is compared
with the last one, and when it is compared with frames further back (a diagnostic for
docs/results-worlds.md, session 32; not part of the product).

    .venv/bin/python docs/lagged_masks.py scenarios/real-alt60-lm6.toml 32 5.0 6.5 2 3 4

Runs one seed through the experiment (rendered frames, the deployed node classes) and, in each frame from
T0 to T1 seconds, prints per crowd how many of its members lie on (or next to) a pixel marked moving: by
the detector's own step 3 (``lag1``: this frame against the last, both tests), by its per-pixel test
against the frame LAG frames back (``lagN``), and by the lagged test as
:meth:`uvteam.vision.motion.MotionDetector._lagged_moving` makes it, against the frames N and 2N back
(``bothN``; the frames those lags name, not the nearest to ``lag_s``), and by the two together
(``lag1+bothN``: step 3 as shipped for N frames of ``lag_s``), with each mask's moving pixels over the
whole frame.
"""

import sys

import cv2
import numpy as np

import uvteam.vision.motion as motion
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam


def main(path: str, seed: int, t0: float, t1: float, lags: list[int]) -> None:
    sc = load_scenario(path)
    team = SimTeam(sc, seed, "pixels")
    world, render, moving = team.sim.world, team.renderer.render, motion.MotionDetector._moving
    now: dict = {}
    ring: list[tuple[np.ndarray, np.ndarray]] = []   # (processed frame, H onto the next one)

    def on_render(pose):
        now.update(pose=pose, t=team.clock.t_s)
        now.setdefault("first", team.clock.t_s)
        return render(pose)

    def on_moving(det, prev, curr, M, warp):
        out = moving(det, prev, curr, M, warp)
        ring.append((prev, M))
        del ring[:-2 * max(lags)]
        t = now["t"] - now["first"]
        if t0 - 1e-6 <= t <= t1 + 1e-6:
            report(det, curr, out, t)
        return out

    def back(det, curr, k: int) -> np.ndarray | None:
        """The per-pixel test against the frame k back (None while fewer are kept)."""
        if len(ring) < k:
            return None
        h, w = curr.shape
        H = np.eye(3)
        for _, M in ring[-k:]:
            H = M @ H
        old = ring[-k][0]
        valid = det._seen_by(H, w, h)
        return det._changed(curr, motion._local_range(curr), motion._warper(H, w, h)(old, cv2.INTER_LINEAR, 0), valid,
                            lagged=True)

    def report(det, curr, out, t: float) -> None:
        h, w = curr.shape
        s = det.cfg.process_scale
        groups = [(g + 0.5) * s - 0.5 for g in world.crowd_groups_px(now["pose"])]

        def on(mask: np.ndarray) -> str:
            near = cv2.dilate(mask, np.ones((3, 3), np.uint8))
            counts = []
            for px in groups:
                q = np.round(px).astype(int)
                ok = (q[:, 0] >= 0) & (q[:, 0] < w) & (q[:, 1] >= 0) & (q[:, 1] < h)
                counts.append(f"{int((near[q[ok, 1], q[ok, 0]] > 0).sum())}/{len(px)}")
            return f"{' '.join(counts)} px {int(np.count_nonzero(mask))}"

        line = [f"t {t:5.2f}  lag1 {on(out)}"]
        for k in lags:
            a, b = back(det, curr, k), back(det, curr, 2 * k)
            if a is not None:
                line.append(f"lag{k} {on(det._cleaned(a.copy()))}")
            if a is not None and b is not None:
                both = det._cleaned(cv2.bitwise_and(a, b))
                line.append(f"both{k} {on(both)}  lag1+both{k} {on(cv2.bitwise_or(out, both))}")
        print("  ".join(line), flush=True)

    team.renderer.render = on_render
    motion.MotionDetector._moving = on_moving
    try:
        team.run(t1 + 0.2)
    finally:
        motion.MotionDetector._moving = moving


if __name__ == "__main__":
    if len(sys.argv) < 6:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), [int(x) for x in sys.argv[5:]])
