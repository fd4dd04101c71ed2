"""The field scenario's false crowds against its crowds missed, as the UAV detector's splitting gap
changes (a diagnostic for docs/results-pixels.md, session 18; not part of the product).

    .venv/bin/python docs/crowd_gap_trade.py 1.5 2.0 2.5     # each gap: the 10 seeds, ~3 min on 2 cores

``UavVisionConfig.crowd_gap_m`` (:mod:`uvteam.vision.uav`): two groups of moving pixels this far apart,
each big enough to be a crowd, are two crowds (1.5 m shipped: the scoring's 2 m between members, less a
person). The scoring joins crowds whose members come within 2 m; the team reports what the detector
splits. Runs every seed of ``../shared/scenarios/field-alt100-lm6.toml`` through the experiment
(rendered frames, the deployed node classes) with the gap given, and prints the scenario's figures with
the frames in which the scoring has one crowd and the team reports two, and the other way round.
"""

import functools
import sys
from multiprocessing import get_context
from pathlib import Path

SCENARIO = Path(__file__).resolve().parents[2] / "shared" / "scenarios" / "field-alt100-lm6.toml"


def run(job: tuple[float, int]):
    gap_m, seed = job
    import uvteam.nodes.uav as uav_node  # noqa: PLC0415
    from uvteam.io.files import load_scenario  # noqa: PLC0415
    from uvteam.vision.uav import UavVisionConfig  # noqa: PLC0415
    from uvteam_sim.experiment import SimTeam  # noqa: PLC0415

    # from the class itself, not from what an earlier job in this worker put in its place
    uav_node.UavVisionConfig = functools.partial(UavVisionConfig, crowd_gap_m=gap_m)
    return SimTeam(load_scenario(str(SCENARIO)), seed, "pixels").run()


def main(gaps: list[float]) -> None:
    from uvteam.io.files import load_scenario  # noqa: PLC0415
    from uvteam.scoring import summarize  # noqa: PLC0415

    seeds = load_scenario(str(SCENARIO)).run.seeds
    print("| crowd_gap_m | false crowds | one true crowd reported as two | two true crowds reported as one "
          "| recall | mean m | p95 m | max m |")
    print("|---|---|---|---|---|---|---|---|")
    with get_context("spawn").Pool(2) as pool:
        for gap_m in gaps:
            boards = pool.map(run, [(gap_m, s) for s in seeds])
            log = [f for b in boards for f in b.frame_log]       # (t, true crowds, matched, reported)
            s = summarize(boards)
            print(f"| {gap_m} | {s['false_crowds']} ({100 * s['false_crowds'] / s['frames']:.2f} % of "
                  f"{s['frames']} frames) | {sum(1 for f in log if f[1] == 1 and f[3] == 2)} "
                  f"| {sum(1 for f in log if f[1] == 2 and f[3] == 1)} | {s['recall']:.3f} | {s['mean_m']:.3f} "
                  f"| {s['p95_m']:.3f} | {s['max_m']:.3f} |", flush=True)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main([float(g) for g in sys.argv[1:]])
