"""Roof-label tracks (uvteam.vision.label_tracks) on synthetic points: a label is confirmed by moving as its UGV
reports, over the ground (through the camera's motion), and nothing else is."""

import numpy as np

from uvteam.vision.label_tracks import CONFIRMED, PENDING, REFUTED, LabelTracks

PX_PER_M = 10.0


def _run(label_v_px_s, reported_v_px_s, frames=12, pan_px_per_frame=(0.0, 0.0), paint=None, prefer_paint=False):
    """A label moving at ``label_v_px_s`` over the ground while its UGV reports ``reported_v_px_s`` (None:
    unknown), seen by a camera that pans; optional still paint at ``paint`` (ground pixels of frame 0), which
    the prediction is nearer with ``prefer_paint``.
    Returns per frame what was taken (ground pixels, or None) and why not."""
    tracks = LabelTracks()
    pan = np.asarray(pan_px_per_frame, float)
    out = []
    for k in range(frames):
        if k:
            tracks.carry(lambda xy: xy - pan)          # the ground moves by -pan in the image
        label = np.array([300.0, 200.0]) + np.asarray(label_v_px_s) * 0.1 * k
        cands = [label]
        if paint is not None:
            cands.append(np.asarray(paint, float))
        img = np.array(cands) - pan * k
        v = None if reported_v_px_s is None else np.asarray(reported_v_px_s, float)
        j, why = tracks.update("red", 0.1 * k, img, v, PX_PER_M, prefer_xy_px=img[-1 if prefer_paint else 0])
        out.append((None if j is None else img[j] + pan * k, why, tracks.state_of("red")))
    return out


def test_a_label_moving_as_its_ugv_reports_is_taken_once_it_has_moved_enough_to_tell():
    # 2 m/s (20 px/s) under a camera panning 15 px a frame: 0.8 m are covered by the fifth frame
    runs = _run((20.0, 0.0), (20.0, 0.0), pan_px_per_frame=(15.0, -4.0))
    assert [got is None for got, *_ in runs] == [True] * 4 + [False] * 8
    assert {why for _, why, _ in runs[:4]} == {"unconfirmed"}
    assert all(np.allclose(got, [300.0 + 2.0 * k, 200.0]) for k, (got, *_) in enumerate(runs) if got is not None)


def test_still_paint_beside_a_moving_ugv_is_refuted_and_never_taken():
    # paint 1.5 m beside the label's way, the prediction on the paint: only the label is ever taken
    runs = _run((20.0, 0.0), (20.0, 0.0), paint=(330.0, 215.0), pan_px_per_frame=(-6.0, 3.0), prefer_paint=True)
    for k, (got, why, states) in enumerate(runs):
        assert got is None or np.allclose(got, [300.0 + 2.0 * k, 200.0]), (k, got)
    assert runs[-1][0] is not None and sorted(runs[-1][2]) == [CONFIRMED, REFUTED]


def test_a_label_moving_unlike_its_ugv_is_refuted():
    # the blob moves 2 m/s east, the UGV reports 2 m/s north: not its label
    runs = _run((20.0, 0.0), (0.0, 20.0))
    assert all(got is None for got, *_ in runs)
    assert runs[-1][1] == "moved_unlike_ugv" and runs[-1][2] == [REFUTED]


def test_without_the_ugvs_velocity_nothing_is_confirmed():
    runs = _run((20.0, 0.0), None)
    assert all(got is None for got, *_ in runs) and runs[-1][2] == [PENDING]


def test_a_confirmed_track_is_kept_through_a_stop_and_a_short_loss():
    tracks = LabelTracks()
    taken = []
    for k in range(40):
        t = 0.1 * k
        moving = k < 10
        x = 300.0 + 20.0 * min(t, 0.9)
        seen = not (20 <= k < 30)                      # lost for 1 s while still
        cands = np.array([[x, 200.0]]) if seen else np.zeros((0, 2))
        j, _ = tracks.update("red", t, cands, np.array([20.0 if moving else 0.0, 0.0]), PX_PER_M)
        taken.append(j is not None)
    assert not any(taken[:4]) and all(taken[4:20]) and all(taken[30:])


def test_a_confirmed_track_is_refuted_by_three_failed_checks_in_a_row_not_one():
    # confirmed over 1 s; then one frame's blob is cut 1.5 m off (a walker across the label): still taken
    # next frame. Then the label stays put while its UGV reports 2 m/s: it fails its check once the UGV has
    # moved 0.8 m more than the label over its last 0.4 s (frame 23) and is refuted on the third failure
    tracks = LabelTracks()
    x, states = 300.0, []
    for k in range(30):
        t = 0.1 * k
        if k < 20:
            x = 300.0 + 20.0 * t
        cand = np.array([[x + (15.0 if k == 12 else 0.0), 200.0]])
        j, why = tracks.update("red", t, cand, np.array([20.0, 0.0]), PX_PER_M)
        states.append((j is not None, tracks.state_of("red")))
    assert all(taken for taken, _ in states[5:20])
    first_refuted = next(k for k, (_, s) in enumerate(states) if s == [REFUTED])
    assert first_refuted == 25 and not any(taken for taken, _ in states[first_refuted:])


def _zigzag():
    """A label driving 2.5 m/s east, reversing to west at 1.0 s and back east at 2.0 s; its UGV's fixes at 5 Hz
    arrive 0.2 s late (the field's receiver). Per frame: whether the label was taken."""
    tracks = LabelTracks()
    taken, x = [], 300.0

    def v_at(t):
        return 25.0 if t < 1.0 or t >= 2.0 else -25.0

    for k in range(40):
        t = 0.1 * k
        if k:
            x += v_at(t - 0.1) * 0.1
        fix_t = np.floor((t - 0.2) / 0.2 + 1e-9) * 0.2          # the newest fix that has arrived
        j, _ = tracks.update("red", t, np.array([[x, 200.0]]), np.array([v_at(fix_t), 0.0]), PX_PER_M,
                             velocity_stamp_s=fix_t)
        taken.append(j is not None)
    return taken


def test_a_late_fix_is_compared_at_its_own_time_so_a_turning_ugv_keeps_its_label():
    # compared at the fix's capture time the label is taken from when the fixes show it has moved 0.8 m (frame
    # 6) to the end, through both reversals (each between two fixes: no verdict on the spans across them)
    taken = _zigzag()
    assert not any(taken[:6]) and all(taken[6:])
