"""In every frame with two crowds reported: the gap between their footprints (boxes round the moving pixels
and their history, on the ground; 0 when they overlap) and whether the two crowds' walkers mingle by the
scenarios' rule (any two members of different crowds within 2 m: scored as one crowd). A diagnostic for
docs/results-worlds.md (session 36, step 9 of :mod:`uvteam.crowds`); not part of the product. Use it on tuning
seeds.

    .venv/bin/python docs/mingling_gaps.py scenarios/real-alt60-lm6-two.toml 1 2
    .venv/bin/python docs/mingling_gaps.py ../shared/scenarios/field-alt100-lm6.toml 1 3

Prints, per band of footprint gap, the frames and those in which the walkers mingled.
"""

import sys

import numpy as np

import uvteam.crowds as crowds
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam

BANDS_M = ((-np.inf, 0.0, "overlapping"), (0.0, 1.0, "apart by up to 1 m"), (1.0, 2.0, "apart by 1-2 m"),
           (2.0, np.inf, "apart by more than 2 m"))


def one_seed(path: str, seed: int) -> list[tuple[float, bool, float, tuple[int, int], float]]:
    """(footprint gap m, mingling, frame time s, the two crowds' ids, their distance m) for each frame of one
    seed with two crowds reported (docs/overlap_keep_probe.py uses the last three)."""
    sc = load_scenario(path)
    if len(sc.crowds) != 2:
        raise SystemExit("a scenario with two crowds, please")
    team = SimTeam(sc, seed, "pixels")
    world = team.sim.world
    mingling, rows = crowds._mingling, []

    def looked_at(reported, cfg):
        if len(reported) == 2:
            a, b = world.members(0), world.members(1)
            closest_m = float(np.sqrt(((a[:, None] - b[None]) ** 2).sum(-1)).min())
            lo = np.array([r.estimate.footprint_en_m.min(0) for r in reported])
            hi = np.array([r.estimate.footprint_en_m.max(0) for r in reported])
            gap = np.maximum(0.0, np.maximum(lo[0] - hi[1], lo[1] - hi[0]))
            overlap = (np.minimum(hi[0], hi[1]) - np.maximum(lo[0], lo[1])).min()
            t = max(r.track.stamp_s for r in reported)   # the frame's (a crowd held by its walk has an older one)
            d = float(np.hypot(reported[0].estimate.east_m - reported[1].estimate.east_m,
                               reported[0].estimate.north_m - reported[1].estimate.north_m))
            rows.append((float(np.hypot(*gap)) if overlap < 0 else -float(overlap), closest_m < 2.0, t,
                         tuple(sorted(r.crowd_id for r in reported)), d))
        return mingling(reported, cfg)

    crowds._mingling = looked_at
    try:
        team.run()
    finally:
        crowds._mingling = mingling
    return rows


def main(path: str, seeds: list[int]) -> None:
    rows = [r for s in seeds for r in one_seed(path, s)]
    gap = np.array([r[0] for r in rows])
    mingle = np.array([r[1] for r in rows], bool)
    print(f"{path} seeds {seeds}: {len(rows)} frames with two crowds reported, walkers mingling in {mingle.sum()}")
    for lo, hi, name in BANDS_M:
        k = (gap > lo) & (gap <= hi) if np.isfinite(lo) else gap <= hi
        print(f"  footprints {name:24s} {k.sum():5d} frames, mingling {mingle[k].sum():4d}")


if __name__ == "__main__":
    main(sys.argv[1], [int(s) for s in sys.argv[2:]])
