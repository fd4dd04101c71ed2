from pathlib import Path

import numpy as np
import pytest

from uvteam.io.files import load_vehicle_config
from uvteam.errors import ConfigError
from uvteam.geo import LocalFrame
from uvteam.planning import plan_stations
from uvteam.io.files import load_scenario
from uvteam.mission import mission_to_plan, plan_to_mission
from uvteam_ground.demo import DEFAULT_SCENARIO

REPO = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((REPO.parent / "shared" / "scenarios").glob("*.toml")) + [DEFAULT_SCENARIO]


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.name)
def test_every_scenario_loads_with_every_field(path):
    sc = load_scenario(path)
    assert sc.ugvs.count == len(sc.ugvs.colors) and sc.run.seeds


def test_scenario_unknown_key_is_an_error(tmp_path):
    text = SCENARIOS[0].read_text().replace("[run]", "[run]\nfast_forward = true")
    p = tmp_path / "s.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_scenario(p)
    assert "run.fast_forward" in str(e.value)


@pytest.mark.parametrize("path", sorted((REPO / "deploy" / "vehicles").glob("*.toml")), ids=lambda p: p.name)
def test_deploy_vehicle_configs_load(path):
    cfg = load_vehicle_config(path)
    assert cfg.role in ("uav", "ugv", "localizer")


@pytest.mark.parametrize(
    "text, key",
    [
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "ugv"\n', "autopilot.url"),              # a UGV needs its autopilot
        ('[vehicle]\nteam = "t"\nid = "u 1"\nrole = "ugv"\n', "vehicle.id"),                # bad id
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "boat"\n', "vehicle.role"),              # unknown role
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "localizer"\n[localizer]\ngate = 3\n', "localizer.gate"),  # typo
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "localizer"\n[localizer]\ngate_px = "3"\n', "localizer.gate_px"),
        ('[vehicle]\nteam = "t"\nrole = "localizer"\n', "vehicle.id"),                      # missing
    ],
)
def test_bad_vehicle_config(tmp_path, text, key):
    p = tmp_path / "v.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_vehicle_config(p)
    assert e.value.key == key and str(p) in str(e.value)


def test_planner_spreads_ugvs_non_collinear_and_in_view():
    rng = np.random.default_rng(0)
    ugvs = {f"ugv{i}": rng.uniform(-30, 30, 2) for i in range(6)}
    plans = plan_stations([0, 0], [1.0, 0.5], ugvs, 100.0, radius_m=40.0, view_half_m=(40.0, 22.0))
    first = np.array([p.en_m[0] for p in plans.values()])
    centre = np.array([1.0, 0.5])  # the crowd one second later
    r = np.sqrt(((first - centre) ** 2).sum(1))
    assert np.allclose(r, 0.8 * 22.0, atol=1e-6)  # shrunk to stay in the UAV's view
    ang = np.sort(np.arctan2(first[:, 1] - centre[1], first[:, 0] - centre[0]))
    assert np.allclose(np.diff(ang), 2 * np.pi / 6, atol=1e-6)  # evenly spread: never collinear
    assert len({tuple(np.round(p, 6)) for p in first}) == 6
    for p in plans.values():
        assert np.all(np.diff(p.stamp_s) > 0) and np.all(p.speed_m_s <= 4.0 + 1e-9)


def _segment_distance(p, a, b):
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / max(np.dot(ab, ab), 1e-12), 0.0, 1.0)
    return float(np.linalg.norm(a + t * ab - p))


@pytest.mark.parametrize("seed", range(40))
def test_planner_never_sends_a_ugv_through_the_crowd(seed):
    # UGVs anywhere around the crowd, bunched or not: every leg up to the station keeps clear of the
    # crowd centre (a motion blob of a UGV driving through a crowd merges with the crowd's blob).
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 7))
    r = 12.0
    ang = rng.uniform(0, 2 * np.pi, n)
    dist = rng.uniform(r, 2 * r, n)
    ugvs = {f"ugv{i}": dist[i] * np.array([np.sin(ang[i]), np.cos(ang[i])]) for i in range(n)}
    plans = plan_stations([0, 0], [0.0, 0.0], ugvs, 0.0, radius_m=r)
    for u, p in plans.items():
        path = np.vstack([ugvs[u], p.en_m[:-2]])  # up to its station (the last two follow the crowd)
        for a, b in zip(path[:-1], path[1:]):
            assert _segment_distance(np.zeros(2), a, b) >= 0.5 * r, u


def test_plan_mission_round_trip():
    frame = LocalFrame(31.485, -111.544)
    plans = plan_stations([0, 0], [2.0, 0.0], {"a": np.array([-12.0, 0.0])}, 1000.0, radius_m=12.0)
    items = plan_to_mission(plans["a"], frame)
    plan = mission_to_plan("a", items, frame, [-12.0, 0.0], 1000.0, 4.0)
    assert len(plan.waypoints) == len(plans["a"].en_m)
    e, n = frame.wgs84_to_ground(np.array([w.lat_deg for w in plan.waypoints]), np.array([w.lon_deg for w in plan.waypoints]))
    np.testing.assert_allclose(np.column_stack([e, n]), plans["a"].en_m, atol=0.02)  # 1e-7 deg on the wire
    np.testing.assert_allclose([w.stamp_s for w in plan.waypoints], plans["a"].stamp_s, atol=0.02)


@pytest.mark.parametrize("lag_deg", [0.0, -30.0, -60.0])
def test_ring_follows_the_crowds_heading_not_the_teams_lag(lag_deg):
    # four UGVs that have slid back round the ring (a crowd faster than their station speed): the
    # stations stay symmetric about the direction of travel, so the team is sent forward again
    v = np.array([2.22, 2.22])
    heading = np.arctan2(v[0], v[1])
    ang = heading + np.radians(45.0 + lag_deg) + np.arange(4) * np.pi / 2
    ugvs = {f"u{i}": 12.0 * np.array([np.sin(a), np.cos(a)]) for i, a in enumerate(ang)}
    plans = plan_stations([0, 0], v, ugvs, 0.0, radius_m=12.0)
    first = np.array([p.en_m[-3] for p in plans.values()]) - v          # stations, crowd-relative
    rel = np.sort((np.degrees(np.arctan2(first[:, 0], first[:, 1]) - heading) + 360.0) % 360.0)
    np.testing.assert_allclose(rel, [45.0, 135.0, 225.0, 315.0], atol=1e-6)
