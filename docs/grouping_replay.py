"""The crowd grouping (:func:`uvteam.crowds.report_crowds`) open loop: record what the localizer hands it
in each run, then replay those recordings through it and score them, in seconds instead of a run's
minute. A diagnostic for docs/results-worlds.md (session 27); not part of the product.

    record: .venv/bin/python docs/grouping_replay.py record OUT_DIR SCENARIO.toml SEED...
    replay: .venv/bin/python docs/grouping_replay.py replay OUT_DIR [GroupingConfig field=value ...]
    time:   .venv/bin/python docs/grouping_replay.py time OUT_DIR   (CPU time of report_crowds per frame)

``record`` runs each seed as ``uvteam experiment --detector pixels`` does (:class:`SimTeam`, the same
scores) and keeps, per frame, the estimates the localizer groups (and the placement's shift in a frame in
which a landmark fit takes over from the camera's pose, session 58), the truth and the Crowds message's
header (``OUT_DIR/<scenario>__seed<N>.pkl``). ``replay`` feeds every recording in ``OUT_DIR`` through
``report_crowds`` with the code on the path (and the config's fields set as given), builds the Crowds
messages as the localizer node does, scores them with :class:`uvteam.scoring.BusScorer`, and prints
the figures per scenario and seed, and the coverage by how many crowds the scoring has and the team
reports in a frame (session 49). Open loop: the UGVs, which plan from the crowds, drove as they did
in the recorded run. Replayed with the code that recorded it, every error and radius is the run's.
"""

import glob
import os
import pickle
import sys
import time
from dataclasses import replace

import numpy as np

import uvteam.nodes.localizer as node_module
from uvteam.crowds import GroupingConfig, GroupingState, report_crowds
from uvteam.io.files import load_scenario
from uvteam.scoring import BusScorer, Scoreboard, summarize
from uvteam_sim.experiment import SimTeam


def record(out_dir: str, path: str, seeds: list[int]) -> None:
    import cv2  # noqa: PLC0415

    cv2.setNumThreads(1)
    sc = load_scenario(path)
    grouping = node_module.report_crowds
    for seed in seeds:
        team, events = SimTeam(sc, seed, "pixels"), []

        def grouped(state, estimates, stamp_s, cfg, shift_en_m=None):
            if shift_en_m is not None:       # a fit took over from the pose (session 58): before its frame
                events.append(("shift", shift_en_m, stamp_s))
            events.append(("frame", estimates, stamp_s))
            return grouping(state, estimates, stamp_s, cfg, shift_en_m)

        on_truth, on_crowds = team.scorer.on_truth, team.scorer.on_crowds
        taps = {on_truth: lambda k, t: (events.append(("truth", k, t)), on_truth(k, t)),
                on_crowds: lambda k, c: (events.append(("crowds", k, replace(c, crowds=()))), on_crowds(k, c))}
        subs = team.hub._hub["subs"]
        subs[:] = [(e, cls, taps.get(h, h), owner) for e, cls, h, owner in subs]
        node_module.report_crowds = grouped
        try:
            board = team.run()
        finally:
            node_module.report_crowds = grouping
        with open(os.path.join(out_dir, f"{sc.name}__seed{seed}.pkl"), "wb") as f:
            pickle.dump({"events": events, "frame": team.loc.frame, "scored_in": team.sim.world.frame,
                         "confirm_hits": team.loc.grouping_cfg.confirm_hits}, f)
        e = np.asarray(board.errors_m)
        print(f"{sc.name} seed {seed} recorded: mean {e.mean():.3f} max {e.max():.2f} false {board.false_crowds}",
              flush=True)


def recorded_events(rec: dict):
    """A recording's events as (kind, key or estimates, message or stamp, shift): a frame's with the placement's
    shift recorded just before it (session 58), None for the others and for a frame without one."""
    shift = None
    for kind, a, b in rec["events"]:
        if kind == "shift":
            shift = a
        elif kind == "frame":
            yield kind, a, b, shift
            shift = None
        else:
            yield kind, a, b, None


def replay(path: str, fields: dict, adjust=None) -> Scoreboard:
    """One recording through ``report_crowds`` and the scoring. ``adjust(stamp_s, reported, truths, scorer)``, if
    given, returns each frame's reported crowds changed (``truths``: the truth messages so far) before they are
    scored (``docs/velocity_oracle.py``)."""
    with open(path, "rb") as f:
        rec = pickle.load(f)
    cfg = GroupingConfig(**{"confirm_hits": rec["confirm_hits"], **fields})
    frame, scorer, state, reported = rec["frame"], BusScorer(rec["scored_in"], Scoreboard()), GroupingState(), []
    truths = []
    for kind, key_or_estimates, msg_or_stamp, shift in recorded_events(rec):
        if kind == "frame":
            state, reported = report_crowds(state, key_or_estimates, msg_or_stamp, cfg, shift)
            if adjust is not None:
                reported = adjust(msg_or_stamp, reported, truths, scorer)
        elif kind == "truth":
            scorer.on_truth(key_or_estimates, msg_or_stamp)
            truths.append(msg_or_stamp)
        else:     # the Crowds message as the localizer node builds it
            scorer.on_crowds(key_or_estimates, replace(msg_or_stamp, crowds=tuple(
                node_module.crowd_message(frame, r) for r in reported)))
    return scorer.finish()


def cpu_time(out_dir: str) -> None:
    """The CPU time ``report_crowds`` takes per frame over every recording in ``out_dir``, nothing else timed
    (run it pinned to one core, alternating the code versions compared)."""
    frames = []
    for p in sorted(glob.glob(os.path.join(out_dir, "*.pkl"))):
        with open(p, "rb") as f:
            rec = pickle.load(f)
        run = [(e, s, shift) for kind, e, s, shift in recorded_events(rec) if kind == "frame"]
        frames.append((GroupingConfig(confirm_hits=rec["confirm_hits"]), run))
    n, t0 = 0, time.process_time()
    for cfg, run in frames:
        state = GroupingState()
        for estimates, stamp_s, shift in run:
            state, _ = report_crowds(state, estimates, stamp_s, cfg, shift)
        n += len(run)
    print(f"report_crowds: {(time.process_time() - t0) / max(n, 1) * 1e6:.0f} us a frame over {n} frames")


def main(argv: list[str]) -> None:
    if argv[0] == "record":
        record(argv[1], argv[2], [int(s) for s in argv[3:]])
        return
    if argv[0] == "time":
        cpu_time(argv[1])
        return
    fields = {k: float(v) for k, v in (a.split("=", 1) for a in argv[2:])}
    runs: dict[str, list[tuple[int, Scoreboard]]] = {}
    for p in sorted(glob.glob(os.path.join(argv[1], "*.pkl"))):
        scenario, seed = os.path.basename(p)[:-4].rsplit("__seed", 1)
        runs.setdefault(scenario, []).append((int(seed), replay(p, fields)))
    for scenario, boards in sorted(runs.items()):
        s = summarize([b for _, b in boards])
        print(f"{scenario}: mean {s['mean_m']:.3f} m, p95 {s['p95_m']:.2f}, max {s['max_m']:.2f}, recall "
              f"{s['recall']:.3f}, false crowds {s['false_crowds']}, UGV as crowd {s['ugv_as_crowd']}, "
              f"in 95 % radius {s['coverage95']:.3f}, id changes {s['id_changes']}")
        print(f"    median radius {np.median(np.concatenate([b.radius95_m for _, b in boards])):.2f} m")
        for seed, b in sorted(boards, key=lambda x: x[0]):
            e, r = np.asarray(b.errors_m), np.asarray(b.radius95_m)
            print(f"    seed {seed}: mean {e.mean():.3f} max {e.max():.2f} false {b.false_crowds} "
                  f"in radius {np.mean(e <= r):.3f} id changes {b.id_changes}")
        for (scored, told), (n, inside) in sorted(_by_frame_kind([b for _, b in boards]).items()):
            print(f"    crowds scored {scored}, reported {told}: {n} crowd-frames, {inside / n:.3f} in the radius")


def _by_frame_kind(boards: list[Scoreboard]) -> dict[tuple[int, int], tuple[int, int]]:
    """The crowd-frames scored, and how many lie in their radius, by how many crowds the scoring has in the frame
    and how many the team reports (3 for three or more)."""
    kinds: dict[tuple[int, int], tuple[int, int]] = {}
    for b in boards:
        of_frame = {round(t, 2): (scored, min(told, 3)) for t, scored, _, told in b.frame_log}
        for t, e, r in zip(b.times_s, b.errors_m, b.radius95_m):
            k = of_frame[round(t, 2)]
            n, inside = kinds.get(k, (0, 0))
            kinds[k] = (n + 1, inside + (e <= r))
    return kinds


if __name__ == "__main__":
    main(sys.argv[1:])
