"""The localizer benchmark runs, and refuses to time a step that gives other results than the frozen one."""

import dataclasses

import numpy as np
import pytest

from uvteam import localizer as now
from uvteam_ground import bench_localize
from reference.localize_4d30179 import localizer as before


def test_the_benchmark_times_both_steps_and_the_yardstick(capsys):
    out = bench_localize.bench_localize(rounds=1, big_rounds=1, blobs=(20, 1200))   # 20: small path, 1200: big path
    assert set(out) == {20, 1200}
    for r in out.values():
        assert r["now_us"] > 0 and r["before_us"] > 0 and r["cv2_us"] > 0 and r["crowds_compared"] > 0
        assert r["max_diff_m"] <= 1e-9
    text = capsys.readouterr().out
    assert "us/step" in text and "before/now" in text


def test_a_step_that_moves_a_crowd_is_not_the_same_step(monkeypatch):
    def moved(state, obs, tracks, cfg):
        st, res = now.localize_step(state, obs, tracks, cfg)
        crowds = tuple(dataclasses.replace(c, east_m=c.east_m + 1e-6) for c in res.crowds)
        return st, dataclasses.replace(res, crowds=crowds)

    class Moved:
        LocalizerState = now.LocalizerState
        localize_step = staticmethod(moved)

    tracks, frames = bench_localize.scene(20)
    with pytest.raises(AssertionError):
        bench_localize.same_results(before, Moved, tracks, frames, before.LocalizerConfig(), now.LocalizerConfig(), cycles=1)
    n, worst = bench_localize.same_results(before, now, tracks, frames, before.LocalizerConfig(),
                                           now.LocalizerConfig(learn_landmark_noise=False, fuse_pose=False), cycles=1)
    assert n == 14 * len(frames) and worst <= 1e-9 and np.isfinite(worst)


def test_the_scene_s_ugvs_have_a_vehicle_s_blob_not_a_piece():
    # a UGV's own blob under the localizer's min_vehicle_blob_m2 takes the rarer path of a piece (its UGV claims
    # the blobs near it): 0-8 % of UGV blobs in the pixel pipeline's runs, where a 0.2 m2 blob made it every one
    tracks, frames = bench_localize.scene(20)
    least_px = now.LocalizerConfig().min_vehicle_blob_m2 * frames[0].px_per_m ** 2
    for f in frames:
        assert (f.blobs.area_px[:6] > least_px).all() and (f.blobs.area_px[6:] < least_px).all()


def test_the_scene_takes_the_deployed_pixel_pipeline_s_path_unless_told_otherwise():
    # the pixel pipeline declares a crowd blob's offset all steady, so the step also propagates the fixes'
    # part of each radius (docs/performance.md 1b, session 48); the sensor model declares it all per frame
    for detector, steady in (("pixels", True), ("sensor", False)):
        tracks, frames = bench_localize.scene(20, detector=detector)
        _, res = now.localize_step(now.LocalizerState(), frames[0], tracks, now.LocalizerConfig())
        assert len(res.crowds) == 14
        assert all((c.steady_radius95_m > 0 and c.fix_sigma_m > 0) == steady for c in res.crowds), detector
    assert bench_localize.scene(20)[1][0].sigma_crowd_blob_frame_px == 0.0
