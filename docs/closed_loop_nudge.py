"""How far a scenario's figures move when nothing but the UGVs' steering is nudged (a diagnostic for
docs/results-pixels.md, session 17; not part of the product).

    .venv/bin/python docs/closed_loop_nudge.py ../shared/scenarios/field-alt100-lm6.toml 0.01 out/nudge.json

The team is a closed loop: each UGV steers by the first crowd the localizer reports (``UgvNode.on_crowds``),
its path moves the landmarks the UAV sees, and those move every later estimate. Runs every seed of the
scenario (rendered frames, the deployed node classes, two at a time) with each UGV told its crowd is
``DELTA_M`` metres east of where the localizer put it; the scoring sees the reports as they are. With
``DELTA_M`` 0 it is the experiment itself (field-alt100-lm6: the table of docs/results-pixels.md to the
digit). Prints the totals over the seeds and writes them, and each seed's, to ``OUT.json``. What a
centimetre moves is the noise any change to what the localizer reports is measured against.
"""

import json
import sys
from dataclasses import replace
from multiprocessing import Pool

import numpy as np

import uvteam.nodes.ugv as ugv
from uvteam.io.files import load_scenario
from uvteam.scoring import Scoreboard, summarize
from uvteam_sim.experiment import SimTeam


TOLD = ugv.UgvNode.on_crowds   # the node's own handler, wrapped afresh for each run (a pool worker runs several)


def run(job: tuple[str, float, int]) -> Scoreboard:
    path, delta_m, seed = job

    def on_crowds(self, key, msg):
        before = self.crowd
        TOLD(self, key, msg)
        if self.crowd is not None and self.crowd is not before:
            self.crowd = replace(self.crowd, en_m=self.crowd.en_m + np.array([delta_m, 0.0]))

    ugv.UgvNode.on_crowds = on_crowds
    return SimTeam(load_scenario(path), seed, "pixels").run()


def main(path: str, delta_m: float, out: str) -> None:
    seeds = load_scenario(path).run.seeds
    with Pool(2) as pool:
        boards = pool.map(run, [(path, delta_m, s) for s in seeds])
    per = {b.seed: summarize([b]) for b in boards}
    total = summarize(boards)
    with open(out, "w") as f:
        json.dump({"scenario": path, "delta_m": delta_m, "all": total, "seeds": per}, f, indent=1)
    print(json.dumps(total))


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(sys.argv[1], float(sys.argv[2]), sys.argv[3])
