"""The bus scorer: frames are timed from the run's first frame, whether or not it was answered."""

from uvteam.geo import LocalFrame
from uvteam.messages import Crowd, Crowds, Truth, TruthCrowd
from uvteam.scoring import BusScorer, summarize

T0 = 1_790_000_000.0
LAT, LON = 31.4850, -111.5440


def test_an_unanswered_first_frame_is_the_runs_start():
    # field-alt100-lm6: the localizer has no origin yet at the first frame and sends nothing for it;
    # scored last (by finish), it was timed from the second frame and logged at t = -0.1 s
    scorer = BusScorer(LocalFrame(LAT, LON))
    crowd = Crowd(1, LAT, LON, (), (), 0.0, 0.0, 1.0, "least_squares", 0)
    for k in range(3):
        stamp = T0 + 0.1 * k
        scorer.on_truth("t", Truth(stamp, k, (TruthCrowd(LAT, LON, 10),), ()))
        if k:
            scorer.on_crowds("c", Crowds("loc1", "uav1", stamp, "least_squares", (), (), (crowd,)))
    board = scorer.finish()
    times = sorted(round(t, 3) for t, *_ in board.frame_log)
    assert times == [0.0, 0.1, 0.2]
    assert [round(t, 3) for t in board.times_s] == [0.1, 0.2]
    assert (board.frames, len(board.errors_m)) == (3, 2)


def test_predicted_frames_are_scored_and_counted_apart():
    # a crowd held unseen (unseen_s > 0) is scored as any other, and said to be predicted
    scorer = BusScorer(LocalFrame(LAT, LON))
    for k, unseen in enumerate((0.0, 0.1, 0.2, 0.0)):
        stamp = T0 + 0.1 * k
        scorer.on_truth("t", Truth(stamp, k, (TruthCrowd(LAT, LON, 10),), ()))
        crowd = Crowd(1, LAT, LON, (), (), 0.0, 0.0, 1.0, "least_squares", 0, unseen)
        scorer.on_crowds("c", Crowds("loc1", "uav1", stamp, "least_squares", (), (), (crowd,)))
    board = scorer.finish()
    assert board.unseen_s == [0.0, 0.1, 0.2, 0.0]
    assert summarize([board])["predicted"] == 2 and len(board.errors_m) == 4


def test_a_true_crowd_reported_under_another_id_is_an_id_change():
    # one true crowd reported as 1, 1, 2, 2, (missed), 1: changes at the third frame and the sixth (the id it
    # was last matched to, across the miss); a second true crowd appearing starts afresh, no change counted
    scorer = BusScorer(LocalFrame(LAT, LON))
    ids = (1, 1, 2, 2, None, 1, 1)
    for k, cid in enumerate(ids):
        stamp = T0 + 0.1 * k
        truth = (TruthCrowd(LAT, LON, 10),) + ((TruthCrowd(LAT + 1e-3, LON, 10),) if k == 6 else ())
        scorer.on_truth("t", Truth(stamp, k, truth, ()))
        crowds = () if cid is None else (Crowd(cid, LAT, LON, (), (), 0.0, 0.0, 1.0, "least_squares", 0),)
        if k == 6:
            crowds += (Crowd(7, LAT + 1e-3, LON, (), (), 0.0, 0.0, 1.0, "least_squares", 0),)
        scorer.on_crowds("c", Crowds("loc1", "uav1", stamp, "least_squares", (), (), crowds))
    board = scorer.finish()
    assert board.id_changes == 2
    assert summarize([board])["id_changes"] == 2
