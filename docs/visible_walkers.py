"""How much of a crowd the camera can show at all: each walker's own contrast in the processed frame, and
where the crowd's centre lies if only the walkers that stand out from the noise are counted (a diagnostic
for docs/results-worlds.md, session 32; not part of the product).

    .venv/bin/python docs/visible_walkers.py scenarios/real-alt60-lm6.toml 32 4.0 8.0

Runs one seed through the experiment (rendered frames, the deployed node classes; the run is the same
as ``uvteam experiment``'s, as nothing here draws from the renderer's random state) and, in each frame
from T0 to T1 seconds, draws the frame again without its sensor noise three ways: with no walker, and
with each walker alone (body, head and shadow). A walker's contrast is the largest change it makes to a
pixel of the grey frame at the detector's ``process_scale``, against the ground as drawn there (roofs,
shadows and vehicles included); the noise is the robust sigma of the compensated difference the
detector measured in that frame. Prints per frame the noise, the walkers' contrasts in noise sigmas,
and how far the centre of the walkers at or over 3 and 5 sigmas lies from the crowd's true centre (the
members' mean, as scored): a placement from what the camera shows is at least that far off, unless it
is carried from earlier frames.
"""

import sys

import cv2
import numpy as np

import uvteam.vision.motion as motion
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam

KS = (3.0, 5.0)


def main(path: str, seed: int, t0: float, t1: float) -> None:
    sc = load_scenario(path)
    team = SimTeam(sc, seed, "pixels")
    world, renderer = team.sim.world, team.renderer
    scale = 1.0     # the detector's, read at its first frame (before T0)
    render, members, sensor = renderer.render, world.members, renderer._sensor
    first: list[float] = []
    sigma: dict = {}
    robust = motion._robust_sigma

    def grey(img: np.ndarray) -> np.ndarray:
        g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float32)
        return cv2.resize(g, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)

    def clean(pose, keep: tuple[int, int] | None) -> np.ndarray:
        """The frame without sensor noise, with only walker ``keep`` (crowd, member), or none."""
        def only(k: int) -> np.ndarray:
            m = members(k).copy()
            mask = np.ones(len(m), bool)
            if keep is not None and keep[0] == k:
                mask[keep[1]] = False
            m[mask] = np.nan
            return m
        world.members, renderer._sensor = only, (lambda f: f)
        try:
            return render(pose)
        finally:
            world.members, renderer._sensor = members, sensor

    def on_render(pose):
        stamp = team.clock.t_s
        out = render(pose)
        first[:] = first or [stamp]
        t = stamp - first[0]
        if t0 - 1e-6 <= t <= t1 + 1e-6:
            study(pose, t)
        return out

    def study(pose, t: float) -> None:
        base = grey(clean(pose, None))
        rows = []
        for k in range(len(sc.crowds)):
            for j in range(len(members(k))):
                d = np.abs(grey(clean(pose, (k, j))) - base)
                rows.append((k, j, float(d.max())))
        pending.append((t, rows))

    def on_sigma(diff, mask):
        s = robust(diff, mask)
        sigma.setdefault("now", s)
        return s

    pending: list = []
    update = motion.MotionDetector.update

    def on_update(det, img, stamp_s, *args, **kwargs):
        nonlocal scale
        scale = det.cfg.process_scale
        sigma.clear()
        out = update(det, img, stamp_s, *args, **kwargs)
        while pending:
            t, rows = pending.pop(0)
            report(t, rows, sigma.get("now", float("nan")))
        return out

    def report(t: float, rows, s: float) -> None:
        groups = world._blob_groups()
        all_m = np.vstack([members(k) for k in range(len(sc.crowds))])
        c = np.array([r[2] for r in rows]) / s
        line = [f"t {t:5.2f} sigma {s:.2f}"]
        for g in groups:
            idx = [i for i, p in enumerate(all_m) if np.min(np.hypot(*(g - p).T)) < 1e-9]
            centre = all_m[idx].mean(0)
            seen = c[idx]
            part = []
            for k in KS:
                v = [i for i, x in zip(idx, seen) if x >= k]
                off = float(np.hypot(*(all_m[v].mean(0) - centre))) if v else float("nan")
                part.append(f">={k:.0f}sig {len(v)}/{len(idx)} off {off:.2f} m")
            line.append(" | ".join(part) + "  contrasts " + " ".join(f"{x:.0f}" for x in sorted(seen)))
        print("  ".join(line), flush=True)

    renderer.render = on_render
    motion._robust_sigma = on_sigma
    motion.MotionDetector.update = on_update
    try:
        team.run(t1 + 0.3)
    finally:
        motion._robust_sigma, motion.MotionDetector.update = robust, update


if __name__ == "__main__":
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
