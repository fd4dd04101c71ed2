"""Faults without loss of state: the whole team on loopback (sensor model, real processes) while every
service kind is killed and restarted, a UGV is frozen for 15 s, and the router is restarted.

After each fault clears (the process is back: its liveliness token, or the router's port, returns) the
latest state reaches every subscriber again within 2 s: crowds at a UGV's subscription, every UGV's
fix, and the frozen or restarted vehicle back among the landmarks. Also: a service started while its
router is unreachable says it is retrying, and stops within 2 s of SIGTERM.
"""

import os
import signal
import subprocess
import sys
import time

import pytest

from uvteam import keys
from uvteam.io.ports import free_port
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Crowds, Fix, Plan
from uvteam.service import StopFlag

from scripted import run_scripted
from uvteam_ground.demo import DEFAULT_SCENARIO, Team, wait_port

pytestmark = pytest.mark.integration
RECOVER_S = 2.0
EVENTS = [   # (scenario second, action, target)
    (3.0, "kill", "localizer"), (5.0, "restart", "localizer"),
    (8.0, "kill", "uav1"), (10.0, "restart", "uav1"),
    (12.0, "stop", "ugv2"), (27.0, "cont", "ugv2"),
    (14.0, "kill", "ugv1"), (16.0, "restart", "ugv1"),
    (19.0, "kill", "router"), (21.0, "restart", "router"),
]


@pytest.fixture(scope="module")
def faulty_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("faults")
    sc = d / "scenario.toml"
    sc.write_text(DEFAULT_SCENARIO.read_text().replace("duration_s = 30.0", "duration_s = 33.0"))
    team = Team(str(sc), workdir=str(d / "run"), frames="sensor")
    stop = StopFlag(install=False)
    rec = {"crowds": [], "fix": [], "plan": [], "alive": [], "acts": {}}
    holder = {}

    def script():
        while "sim" not in team.procs and not stop.is_set():
            time.sleep(0.05)
        probe = holder["probe"] = ZenohBus.open(team.member_bus("view"))
        probe.subscribe(keys.key(team.team, team.localizer, "crowds"), Crowds,
                        lambda k, m: rec["crowds"].append((time.time(), m)))
        probe.subscribe(keys.all_vehicles(team.team, "fix"), Fix, lambda k, m: rec["fix"].append((time.time(), m)))
        probe.subscribe(keys.all_vehicles(team.team, "plan"), Plan, lambda k, m: rec["plan"].append((time.time(), m)))
        probe.watch_alive(keys.alive_all(team.team), lambda k, up: rec["alive"].append((time.time(), keys.vehicle_of(k), up)))
        t0 = time.time()
        for at, act, name in sorted(EVENTS):
            while time.time() - t0 < at and not stop.is_set():
                time.sleep(0.02)
            p = team.procs[name]
            if act == "kill":
                team.kill(name)
            elif act == "restart":
                p.wait(timeout=5)
                team.restart(name)
                if name == "router":
                    wait_port(team.router_port, 10.0)
            elif act == "stop":
                os.killpg(p.pid, signal.SIGSTOP)
            elif act == "cont":
                os.killpg(p.pid, signal.SIGCONT)
            rec["acts"][(act, name)] = time.time()

    summary, codes = run_scripted(team, stop, script, holder, d / "view.txt")
    return team, summary, codes, rec


def _back_alive(rec, name, after):
    return next(w for w, v, up in rec["alive"] if v == name and up and w > after)


def _first(rows, after, ok=lambda m: True):
    got = next((w for w, m in rows if w > after and ok(m)), None)
    print(f"recovered {'-' if got is None else f'{got - after:.2f} s'} after the fault cleared")
    return got


def test_every_service_kind_killed_comes_back_with_its_state(faulty_run):
    team, summary, codes, rec = faulty_run
    # the localizer: crowds reach the UGVs' subscription again within 2 s of it being back
    back = _back_alive(rec, team.localizer, rec["acts"][("restart", "localizer")])
    got = _first(rec["crowds"], back, lambda m: len(m.crowds) > 0)
    assert got is not None and got - back <= RECOVER_S, (got and got - back)
    # the UAV: its detections turn into crowds again
    back = _back_alive(rec, team.uav, rec["acts"][("restart", "uav1")])
    got = _first(rec["crowds"], back, lambda m: len(m.crowds) > 0)
    assert got is not None and got - back <= RECOVER_S, (got and got - back)
    # a UGV: its fix and its plan are out again, and it is a landmark again
    back = _back_alive(rec, "ugv1", rec["acts"][("restart", "ugv1")])
    for what in ("fix", "plan"):
        got = _first(rec[what], back, lambda m: m.vehicle == "ugv1")
        assert got is not None and got - back <= RECOVER_S, (what, got and got - back)
    got = _first(rec["crowds"], back, lambda m: "ugv1" in m.landmarks_used)
    assert got is not None and got - back <= RECOVER_S + 1.0, got and got - back   # + one tracking interval


def test_a_frozen_ugv_is_dropped_then_taken_back(faulty_run):
    team, summary, codes, rec = faulty_run
    stopped, resumed = rec["acts"][("stop", "ugv2")], rec["acts"][("cont", "ugv2")]
    gone = next(w for w, v, up in rec["alive"] if v == "ugv2" and not up and w > stopped)
    assert gone - stopped < 5.0                                  # the 3 s lease, not the default 10 s
    during = [m for w, m in rec["crowds"] if gone + 0.5 < w < resumed]
    assert during and not any("ugv2" in m.landmarks_used for m in during)
    got = _first(rec["fix"], resumed, lambda m: m.vehicle == "ugv2")
    assert got is not None and got - resumed <= RECOVER_S
    got = _first(rec["crowds"], resumed, lambda m: "ugv2" in m.landmarks_used)
    assert got is not None and got - resumed <= RECOVER_S + 1.0


def test_a_router_restart_loses_no_more_than_it_must(faulty_run):
    team, summary, codes, rec = faulty_run
    up = rec["acts"][("restart", "router")]                        # its port answers again
    got = _first(rec["crowds"], up, lambda m: len(m.crowds) > 0)
    assert got is not None and got - up <= RECOVER_S, got and got - up
    for u in [u for u in team.ugvs if u != "ugv2"] + [team.uav]:
        got = _first(rec["fix"], up, lambda m, u=u: m.vehicle == u)
        assert got is not None and got - up <= RECOVER_S, (u, got and got - up)
    bad = {n: c for n, c in codes.items() if c not in (0, -signal.SIGTERM, None) and n not in team.expected_exit}
    assert not bad, {n: team.tail(n) for n in bad}


def test_a_service_waits_for_its_router_and_stops_when_told(tmp_path):
    port = free_port()          # nothing listens there
    cfg = tmp_path / "loc.toml"
    cfg.write_text(f'[vehicle]\nteam = "t"\nid = "loc1"\nrole = "localizer"\n\n[bus]\nmode = "client"\n'
                   f'connect = ["tcp/127.0.0.1:{port}"]\n')
    for sig in (signal.SIGTERM, signal.SIGINT):
        p = subprocess.Popen([sys.executable, "-m", "uvteam", "localizer", "--config", str(cfg)],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
        time.sleep(3.0)
        t = time.monotonic()
        p.send_signal(sig)
        try:
            out = p.communicate(timeout=5)[0]
        finally:
            if p.poll() is None:
                p.kill()
        took = time.monotonic() - t
        assert "cannot reach tcp/127.0.0.1" in out and "retrying" in out, out
        assert p.returncode == 0 and took <= 2.0, (sig, p.returncode, took, out)
