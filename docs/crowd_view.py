"""What the motion detector made of a crowd at given times (a diagnostic for docs/results-worlds.md,
session 13; not part of the product).

    .venv/bin/python docs/crowd_view.py scenarios/real-alt60-lm6.toml 4 out/view 17.3 33.0

Runs one seed of a scenario through the experiment (rendered frames, the deployed node classes) up to
the last time asked for and, at each time (seconds from the first frame), writes
``<prefix>_<t>.png``: the frame at the detector's processing scale with its joined motion mask (step 5
of :mod:`uvteam.vision.motion`) in red, each connected component boxed with its area in full-resolution
pixels (green: big enough to be a crowd, blue: not), every crowd member's true position as a yellow
dot and the crowd's true centre (the members' mean, what the scoring holds the report to; crowds that
mingle are one, as the scoring counts them) as a yellow cross (``SimWorld.crowd_groups_px``). Prints the components' areas and each crowd's members that no component holds.
"""

import sys
from pathlib import Path

import cv2
import numpy as np

import uvteam.vision.motion as motion
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam


def main(path: str, seed: int, prefix: str, times_s: list[float]) -> None:
    sc = load_scenario(path)
    Path(prefix).parent.mkdir(parents=True, exist_ok=True)
    team = SimTeam(sc, seed, "pixels")
    world = team.sim.world
    first: list[float] = []
    frame: dict = {}
    update, components = motion.MotionDetector.update, motion.MotionDetector._components
    render = team.renderer.render

    def on_render(pose):       # the pose the frame was drawn with (asking the world again draws new jitter)
        frame["pose"] = pose
        return render(pose)

    def on_update(det, img, stamp_s, *args, **kwargs):
        first[:] = first or [stamp_s]
        frame.update(t=stamp_s - first[0], img=img)
        return update(det, img, stamp_s, *args, **kwargs)

    def on_components(det, joined, carve):
        out = components(det, joined, carve)
        for t in times_s:
            if abs(frame["t"] - t) < 0.05:
                draw(det.cfg, joined, f"{prefix}_{t:.1f}.png")
        return out

    def draw(cfg, joined, name):
        s = cfg.process_scale
        img = cv2.resize(frame["img"], (joined.shape[1], joined.shape[0]), interpolation=cv2.INTER_AREA)
        img[joined > 0] = (0.5 * img[joined > 0] + [0, 0, 127]).astype(np.uint8)
        _, labels, stats, _ = cv2.connectedComponentsWithStats(joined, connectivity=8)
        for x, y, w, h, a in stats[1:]:
            crowd = a / (s * s) >= cfg.min_area_px
            cv2.rectangle(img, (int(x), int(y)), (int(x + w), int(y + h)), (0, 255, 0) if crowd else (255, 0, 0), 1)
            cv2.putText(img, str(int(a / (s * s))), (int(x), int(y) - 2), cv2.FONT_HERSHEY_SIMPLEX, 0.35, (255, 255, 0))
        pose = frame["pose"]
        print(f"t {frame['t']:.1f} s: components (full-res px) {sorted(int(a / (s * s)) for a in stats[1:, 4])}")
        for k, full_px in enumerate(world.crowd_groups_px(pose)):
            px = (full_px + 0.5) * s - 0.5
            lost = 0
            for x, y in px:
                cv2.circle(img, (int(round(x)), int(round(y))), 1, (0, 255, 255), -1)
                xi, yi = int(round(x)), int(round(y))
                inside = 0 <= xi < joined.shape[1] and 0 <= yi < joined.shape[0] and labels[yi, xi] > 0
                lost += not inside
            c = px.mean(0)
            cv2.drawMarker(img, (int(round(c[0])), int(round(c[1]))), (0, 255, 255), cv2.MARKER_CROSS, 9)
            print(f"  crowd {k}: {lost} of {len(px)} members on no component")
        cv2.imwrite(name, img)
        print(f"  wrote {name}")

    team.renderer.render = on_render
    motion.MotionDetector.update = on_update
    motion.MotionDetector._components = on_components
    team.run(max(times_s) + 0.2)


if __name__ == "__main__":
    if len(sys.argv) < 5:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3], [float(t) for t in sys.argv[4:]])
