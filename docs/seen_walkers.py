"""Per frame, between two times: how many of each crowd's walkers show motion, and how far the centroid of
those lies from the crowd's true centre, beside how far the detector's blob and its moving pixels' plain
centroid lie from it. What any placement by what moved is off by before prediction is the first distance;
what the detector adds by weighing walkers by their moving pixels is the rest. A diagnostic for
docs/results-worlds.md (session 40); not part of the product. Use it on tuning seeds or to trace a figure
already reported.

    .venv/bin/python docs/seen_walkers.py scenarios/real-alt120-lm6.toml 9 2.0 5.0

A walker shows motion when the motion history (step 4 of :mod:`uvteam.vision.motion`, after its opening)
holds a pixel within 0.35 m of it. The blob is the detector's blob nearest the crowd's true centre in the
image; its plain centroid is that of the history's moving pixels in the blob's box. Distances are ground
metres at the frame's scale (the camera's height over the ground below it); the reported error and 95 %
radius are the scoring's, for the crowd the team reported nearest.
"""

import sys

import numpy as np

import uvteam.vision.motion as motion
from uvteam.camera import project
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import T0, SimTeam
from uvteam_sim.world import PERSON_CENTRE_HEIGHT_M

SHOWS_M = 0.35   # a moving pixel this near a walker: the walker shows motion


def main(path: str, seed: int, t0_s: float, t1_s: float) -> None:
    sc = load_scenario(path)
    team = SimTeam(sc, seed, "pixels")
    world = team.sim.world
    frame: dict = {}
    rows: dict[float, list] = {}
    render, history, update = team.renderer.render, motion.MotionDetector._history, motion.MotionDetector.update

    def on_render(pose):       # the pose the frame was drawn with (asking the world again draws new jitter)
        frame["pose"] = pose
        return render(pose)

    def members_px(k: int, pose) -> np.ndarray:
        m = world.members(k)
        return project(world.camera, pose, np.column_stack([m, world.terrain_up_m(m) + PERSON_CENTRE_HEIGHT_M]))

    def px_per_m(pose) -> float:
        below = float(world.terrain_up_m(np.array([[pose.east_m, pose.north_m]]))[0])
        return world.camera.focal_px / (pose.up_m - below)

    def on_history(det, moving, warp, M, dt_s):
        recent = history(det, moving, warp, M, dt_s)
        frame["recent"] = recent
        t = frame["t"]
        if not t0_s <= t <= t1_s:
            return recent
        s, pose = det.cfg.process_scale, frame["pose"]
        r = SHOWS_M * px_per_m(pose) * s
        h, w = recent.shape
        out = []
        for k in range(len(sc.crowds)):
            m = world.members(k)
            shows = []
            for x, y in (members_px(k, pose) + 0.5) * s - 0.5:
                x0, x1, y0, y1 = int(max(0, x - r)), int(min(w, x + r + 1)), int(max(0, y - r)), int(min(h, y + r + 1))
                shows.append(x1 > x0 and y1 > y0 and bool(recent[y0:y1, x0:x1].any()))
            shows = np.array(shows)
            off = float(np.hypot(*(m[shows].mean(0) - m.mean(0)))) if shows.any() else float("nan")
            out.append([int(shows.sum()), len(m), off])
        rows[t] = out
        return recent

    def on_update(det, img, stamp_s, *args, **kwargs):
        frame["t"] = round(stamp_s - T0, 2)
        res = update(det, img, stamp_s, *args, **kwargs)
        t = frame["t"]
        if t in rows and len(res.blobs):
            pose, s = frame["pose"], det.cfg.process_scale
            ppm = px_per_m(pose)
            for k, row in enumerate(rows[t]):
                c = members_px(k, pose).mean(0)
                j = int(np.argmin(np.hypot(*(res.blobs.xy_px - c).T)))
                x0, y0, x1, y1 = res.blobs.xyxy_px[j]
                ox, oy = int(x0 * s), int(y0 * s)
                ys, xs = np.nonzero(frame["recent"][oy:int(y1 * s) + 1, ox:int(x1 * s) + 1])
                plain = (np.array([xs.mean() + ox, ys.mean() + oy]) + 0.5) / s - 0.5 if len(xs) else c
                row += [float(np.hypot(*(res.blobs.xy_px[j] - c))) / ppm, float(np.hypot(*(plain - c))) / ppm,
                        float(res.blobs.area_px[j])]
        return res

    team.renderer.render = on_render
    motion.MotionDetector._history = on_history
    motion.MotionDetector.update = on_update
    try:
        board = team.run(t1_s + 0.2)
    finally:
        motion.MotionDetector._history, motion.MotionDetector.update = history, update
    reported = {round(t, 1): (e, r) for t, e, r in zip(board.times_s, board.errors_m, board.radius95_m)}
    print("t s   crowd: walkers showing motion, their centroid's offset m | blob m, its pixels' plain centroid m, "
          "moving px | reported m (95 % radius m)")
    for t in sorted(rows):
        cells = []
        for row in rows[t]:
            cell = f"{row[0]:2d}/{row[1]:2d} {row[2]:5.2f}"
            if len(row) > 3:
                cell += f" | {row[3]:5.2f} {row[4]:5.2f} {row[5]:6.0f}"
            cells.append(cell)
        e = reported.get(round(t, 1))
        print(f"{t:5.1f}  " + "  ".join(cells) + ("" if e is None else f" | {e[0]:5.2f} ({e[1]:.2f})"))


if __name__ == "__main__":
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
