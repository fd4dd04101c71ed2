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


UGV = '[vehicle]\nteam = "t"\nid = "u1"\nrole = "ugv"\n'
LOC = '[vehicle]\nteam = "t"\nid = "l1"\nrole = "localizer"\n'


@pytest.mark.parametrize(
    "text, key",
    [
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "ugv"\n', "autopilot.url"),              # a UGV needs its autopilot
        ('[vehicle]\nteam = "t"\nid = "u 1"\nrole = "ugv"\n', "vehicle.id"),                # bad id
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "boat"\n', "vehicle.role"),              # unknown role
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "localizer"\n[localizer]\ngate = 3\n', "localizer.gate"),  # typo
        ('[vehicle]\nteam = "t"\nid = "u1"\nrole = "localizer"\n[localizer]\ngate_px = "3"\n', "localizer.gate_px"),
        ('[vehicle]\nteam = "t"\nrole = "localizer"\n', "vehicle.id"),                      # missing
        (UGV + '[autopilot]\nurl = "udpin:0.0.0.0:1"\nsystem_id = 300\n', "autopilot.system_id"),  # MAVLink ids are 1-255
        (UGV + '[autopilot]\nurl = "udpin:0.0.0.0:1"\n[ugv]\nstation_radius_m = nan\n', "ugv.station_radius_m"),  # NaN
        (UGV + '[autopilot]\nurl = "udpin:0.0.0.0:1"\n[ugv]\nmax_speed_m_s = -1.0\n', "ugv.max_speed_m_s"),  # negative
        (LOC + '[localizer]\ntracking_interval_s = 0\n', "localizer.tracking_interval_s"),   # a zero interval
        (LOC + '[localizer]\nugvs = ["ugv1", 3]\n', "localizer.ugvs"),                      # an id that is no string
        (LOC + '[localizer]\nugvs = ["ugv1", "../x"]\n', "localizer.ugvs"),                 # an id that is a path
        (LOC + '[localizer]\nimage_coordinates = "colour"\n', "localizer.image_coordinates"),  # not a word we know
        ('[vehicle]\nteam = "t"\nid = "uav1"\nrole = "uav"\n[autopilot]\nurl = "udpin:0.0.0.0:1"\n'
         '[uav]\ndetector = "pixels"\ncolors = { purple = "ugv1" }\n', "uav.colors.purple"),  # an unknown color
    ],
)
def test_bad_vehicle_config(tmp_path, text, key):
    p = tmp_path / "v.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_vehicle_config(p)
    assert e.value.key == key and str(p) in str(e.value)


@pytest.mark.parametrize("content", [b"\x89PNG\r\n\x1a\n\x00\xff\xfe", b"[vehicle\nteam = "])   # binary, broken TOML
def test_unreadable_config_is_a_clear_error(tmp_path, content):
    p = tmp_path / "v.toml"
    p.write_bytes(content)
    with pytest.raises(ConfigError) as e:
        load_vehicle_config(p)
    assert e.value.key == "<file>" and str(p) in str(e.value)


def test_a_bad_config_exits_2_before_anything_starts(tmp_path):
    import subprocess
    import sys

    p = tmp_path / "uav.toml"
    p.write_text('[vehicle]\nteam = "t"\nid = "uav1"\nrole = "uav"\n[autopilot]\nurl = "udpin:127.0.0.1:9"\n'
                 '[uav]\ndetector = "pixels"\ncolors = { purple = "ugv1" }\n')
    r = subprocess.run([sys.executable, "-m", "uvteam", "uav", "--config", str(p)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "uav.colors.purple" in r.stderr and "unknown color" in r.stderr


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


# what a deployment sets for itself; everything else is tuning, which the shipped files leave at the
# defaults that the demo and the experiment run with (uvteam.team)
WIRING = {"bus": {"zenoh_config", "mode", "connect", "listen"},
          "autopilot": {"url", "system_id", "component_id", "signing_key_file"},
          "uav": {"detector", "camera", "hfov_deg", "label_side_m", "colors", "gimbal", "mount_roll_deg", "mount_pitch_deg",
                  "mount_yaw_deg", "annotate_http", "annotate_video"},
          "ugv": {"uav", "localizer", "team_ugvs", "station_radius_m", "max_speed_m_s", "view_half_width_m",
                  "view_half_height_m", "camera", "camera_hfov_deg", "camera_yaw_deg", "camera_ref_distance_m",
                  "camera_ref_box_height_px", "person_height_m"},
          "localizer": {"uav", "ugvs", "origin_lat_deg", "origin_lon_deg"}}


@pytest.mark.parametrize("path", sorted((REPO / "deploy" / "vehicles").glob("*.toml")), ids=lambda p: p.name)
def test_shipped_configs_set_no_tuning_and_use_the_secure_profile(path):
    from uvteam.io.files import tomllib  # tomli before Python 3.11

    raw = tomllib.loads(path.read_text())
    for section, keys_set in raw.items():
        if section != "vehicle":
            assert set(keys_set) <= WIRING[section], (section, set(keys_set) - WIRING[section])
    cfg = load_vehicle_config(path)
    assert cfg.bus.config_file.endswith(f"secrets/border1/{cfg.id}.json5") and cfg.bus.connect[0].startswith("tls/")


def test_team_configs_are_the_defaults_plus_wiring():
    from dataclasses import fields

    from uvteam.config import VehicleConfig
    from uvteam.team import TeamLayout, team_configs

    sc = load_scenario(SCENARIOS[0])
    for cfg in team_configs(sc, TeamLayout.for_scenario(sc)).values():
        default = VehicleConfig(cfg.team, cfg.id, cfg.role)
        for section in ("autopilot", "uav", "ugv", "localizer"):
            for f in fields(getattr(cfg, section)):
                mine, base = getattr(getattr(cfg, section), f.name), getattr(getattr(default, section), f.name)
                if f.name not in WIRING[section] and not (f.name == "image_coordinates" and section == "localizer"):
                    assert mine == base or (mine != mine and base != base), (cfg.id, section, f.name)


def test_a_ugv_ahead_of_a_fast_crowd_is_not_sent_round_a_ring_the_crowd_carries_away():
    # paper-fig7-alt50 seed 9 (rendered): a crowd walking north-east at 3.1 m/s, a UGV 9 m ahead of it
    # whose station is front-right. Judged in still ground coordinates, its straight way "crossed" the
    # crowd, so it was sent outwards round the ring ahead of a crowd faster than it; it fell back onto the
    # front-left UGV's station and two landmarks stood together (crowds 3-5 m off, radii 20-300 m).
    v = np.array([2.2, 2.2])
    ugvs = {"ugv1": np.array([0.0, -13.0]), "ugv2": np.array([-14.0, -7.0]), "ugv3": np.array([-9.0, 8.0]),
            "ugv4": np.array([6.0, 7.0])}
    plans = plan_stations([0.0, 0.0], v, ugvs, 0.0, radius_m=12.0, step_s=1.0, horizon_s=3.0)
    station = plans["ugv4"].en_m[-1] - 3.0 * v                 # the last waypoint, 3 steps on
    assert station[0] > 10 and abs(station[1]) < 2            # its station: east of the crowd
    for j, wp in enumerate(plans["ugv4"].en_m):                # seen from the crowd at each waypoint's step
        assert np.linalg.norm(wp - (j + 1) * v - station) <= np.linalg.norm(ugvs["ugv4"] - station) + 1e-9
    stations = [p.en_m[-1] for p in plans.values()]
    assert min(np.linalg.norm(a - b) for i, a in enumerate(stations) for b in stations[i + 1:]) > 12
