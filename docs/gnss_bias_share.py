"""How much of a drifting-GNSS world's error is the part of the UGVs' biases that the image cannot see (a
diagnostic for docs/results-worlds.md, session 42; not part of the product).

    .venv/bin/python docs/gnss_bias_share.py scenarios/real-alt60-lm6-gnss1drift.toml OUT_DIR

Every landmark moved by the same offset leaves the image-to-ground fit as good as before, so the mean of the
six UGVs' GNSS biases goes into every crowd placed through it. Per seed of the scenario this prints the length of
that mean (the world's own drift, ``SimWorld.gnss_drift``, halfway through the run; it drifts little in a run)
beside the seed's mean error as ``uvteam experiment`` measured it in ``OUT_DIR/runs``, and their correlation.
"""

import json
import os
import sys

import numpy as np

from uvteam.io.files import load_scenario
from uvteam_sim.world import SimWorld


def main(path: str, out_dir: str) -> None:
    sc = load_scenario(path)
    common, errors = [], []
    for seed in sc.run.seeds:
        run = os.path.join(out_dir, "runs", f"{sc.name}__pixels__seed{seed}.json")
        if not os.path.exists(run):
            continue
        world = SimWorld(sc, seed)
        dt_s = 1.0 / sc.run.frame_rate_hz
        for _ in range(int(sc.run.duration_s / 2.0 / dt_s)):
            world.step(dt_s)
        with open(run) as f:
            mean_m = float(np.mean(json.load(f)["errors_m"]))
        common.append(float(np.hypot(*world.gnss_drift.mean(0))))
        errors.append(mean_m)
        print(f"{sc.name} seed {seed}: the biases' common part {common[-1]:.2f} m, mean error {mean_m:.2f} m")
    if len(common) > 2:
        print(f"correlation over {len(common)} seeds: {np.corrcoef(common, errors)[0, 1]:.2f}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
