"""The field scenario's false crowds against its crowds missed, as the UAV detector's splitting gap
changes (a diagnostic for docs/results-pixels.md, session 18; not part of the product).

    .venv/bin/python docs/crowd_gap_trade.py 1.5 2.0 2.5     # each gap: the 10 seeds, ~3 min on 2 cores

``UavVisionConfig.crowd_gap_m`` (:mod:`uvteam.vision.uav`): two groups of moving pixels this far apart,
each big enough to be a crowd, are two crowds (1.5 m shipped: the scoring's 2 m between members, less a
person). The scoring joins crowds whose members come within 2 m; the team reports what the detector
splits. Runs every seed of ``../shared/scenarios/field-alt100-lm6.toml`` through the experiment
(rendered frames, the deployed node classes) with the gap given, and prints the scenario's figures with
the frames in which the scoring has one crowd and the team reports two, and the other way round; then,
per gap, how often the team reports two crowds against the least distance between members of the two
(the simulator's own, the quantity the scoring's 2 m applies to), and, where the scoring has one crowd,
how many groups its 2 m rule makes of all walkers when not told whose each is (session 19).
"""

import functools
import sys
from multiprocessing import get_context
from pathlib import Path

import numpy as np

SCENARIO = Path(__file__).resolve().parents[2] / "shared" / "scenarios" / "field-alt100-lm6.toml"
LEAST_BINS_M = (0.0, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, np.inf)
_ORIGINAL = {}   # the simulator's own truth method, kept once per worker (never a wrapper of a wrapper)


def blind_groups(members_en: np.ndarray, link_m: float = 2.0, least: int = 3) -> int:
    """Groups of at least ``least`` walkers that the scoring's rule (walkers under ``link_m`` apart are
    together) makes of all walkers when it is not told who belongs to which crowd."""
    near = np.sqrt(((members_en[:, None] - members_en[None]) ** 2).sum(-1)) < link_m
    label = np.arange(len(members_en))
    while True:   # each walker takes the least label among its neighbours until none changes
        new = np.where(near, label[None, :], len(label)).min(1)
        if np.array_equal(new, label):
            break
        label = new
    return int(np.sum(np.bincount(label) >= least))


def run(job: tuple[float, int]):
    gap_m, seed = job
    import uvteam.nodes.uav as uav_node  # noqa: PLC0415
    from uvteam.io.files import load_scenario  # noqa: PLC0415
    from uvteam.vision.uav import UavVisionConfig  # noqa: PLC0415
    import uvteam_sim.simulation as simulation  # noqa: PLC0415
    from uvteam_sim.experiment import SimTeam  # noqa: PLC0415

    # from the class itself, not from what an earlier job in this worker put in its place
    uav_node.UavVisionConfig = functools.partial(UavVisionConfig, crowd_gap_m=gap_m)
    truth = _ORIGINAL.setdefault("truth", simulation.Simulation.truth)
    least: dict[float, tuple[float, int]] = {}   # per frame: least distance m, blind groups

    def truth_and_least(self, t_s, seq, ugv_ids):
        a, b = self.world.members(0), self.world.members(1)
        least[round(self.t0_unix_s + t_s, 3)] = (float(np.sqrt(((a[:, None] - b[None]) ** 2).sum(-1)).min()),
                                                 blind_groups(np.vstack([a, b])))
        return truth(self, t_s, seq, ugv_ids)

    simulation.Simulation.truth = truth_and_least
    try:
        board = SimTeam(load_scenario(str(SCENARIO)), seed, "pixels").run()
    finally:
        simulation.Simulation.truth = truth
    return board, [least[round(board.start_s + f[0], 3)] for f in board.frame_log]


def main(gaps: list[float]) -> None:
    from uvteam.io.files import load_scenario  # noqa: PLC0415
    from uvteam.scoring import summarize  # noqa: PLC0415

    seeds = load_scenario(str(SCENARIO)).run.seeds
    print("| crowd_gap_m | false crowds | one true crowd reported as two | two true crowds reported as one "
          "| recall | mean m | p95 m | max m |")
    print("|---|---|---|---|---|---|---|---|")
    curves = []
    with get_context("spawn").Pool(2) as pool:
        for gap_m in gaps:
            runs = pool.map(run, [(gap_m, s) for s in seeds])
            boards = [b for b, _ in runs]
            log = [f for b in boards for f in b.frame_log]       # (t, true crowds, matched, reported)
            least = np.array([d for _, ds in runs for d, _ in ds])
            blind = np.array([g for _, ds in runs for _, g in ds])
            two = np.array([f[3] >= 2 for f in log])
            one_true = np.array([f[1] == 1 for f in log])
            curves.append((gap_m, np.histogram(least, LEAST_BINS_M)[0], np.histogram(least[two], LEAST_BINS_M)[0],
                           [(int(np.sum(one_true & (np.minimum(blind, 3) == g))),
                             int(np.sum(one_true & two & (np.minimum(blind, 3) == g)))) for g in (0, 1, 2, 3)]))
            s = summarize(boards)
            print(f"| {gap_m} | {s['false_crowds']} ({100 * s['false_crowds'] / s['frames']:.2f} % of "
                  f"{s['frames']} frames) | {sum(1 for f in log if f[1] == 1 and f[3] == 2)} "
                  f"| {sum(1 for f in log if f[1] == 2 and f[3] == 1)} | {s['recall']:.3f} | {s['mean_m']:.3f} "
                  f"| {s['p95_m']:.3f} | {s['max_m']:.3f} |", flush=True)
    bins = [f"{lo:g}-{hi:g} m" if np.isfinite(hi) else f">= {lo:g} m" for lo, hi in zip(LEAST_BINS_M, LEAST_BINS_M[1:])]
    print("\nFrames in which the team reports two crowds, by the least distance between members of the two "
          "(the scoring joins them under 2 m): reported two / frames\n")
    print("| crowd_gap_m | " + " | ".join(bins) + " |")
    print("|---|" + "---|" * len(bins))
    for gap_m, frames, two, _ in curves:
        print(f"| {gap_m} | " + " | ".join(f"{t} / {n} ({t / max(n, 1):.2f})" for t, n in zip(two, frames)) + " |")
    print("\nFrames in which the scoring has one crowd, by the groups of 3 or more walkers that its 2 m rule "
          "makes when not told who belongs to which crowd: reported two / frames\n")
    print("| crowd_gap_m | no group | 1 group | 2 groups | 3 or more |")
    print("|---|---|---|---|---|")
    for gap_m, _, _, blind in curves:
        print(f"| {gap_m} | " + " | ".join(f"{t} / {n}" for n, t in blind) + " |")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main([float(g) for g in sys.argv[1:]])
