"""The secure profile with real processes on loopback: `uvteam certs` makes a team, `uvteam router`
runs with the router config it wrote (TLS, client certificates, access control), and members connect
with theirs. zenoh's access control drops a denied message silently (no error at the publisher), so a
denial is shown by a marker: the same publisher puts the denied message and then an allowed one on the
same path through the router; when the marker has arrived and the denied one has not, it was dropped.

Also: `uvteam router --zenoh-config FILE` listens where the file says (it bound tcp/0.0.0.0:7447 before).
"""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh

from uvteam import keys
from uvteam.io.ports import free_port
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Fix
from uvteam.service import StopFlag
from uvteam_ground import certs
from uvteam_ground.demo import DEFAULT_SCENARIO, Team, run_demo, wait_port

pytestmark = pytest.mark.integration
REPO = Path(__file__).resolve().parents[2]
TEAM = "sec"


def _uvteam(*args, cwd, log):
    return subprocess.Popen([sys.executable, "-m", "uvteam", *args], cwd=cwd, stdout=log, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL, start_new_session=True)


def _stop(p: subprocess.Popen) -> int:
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGTERM)
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=5)
    return p.returncode


class Secure:
    """A team's secrets in ``dir/secrets`` (paths in the configs relative to ``dir``, as deployed), a
    rogue CA's ``ugv1`` in ``dir/rogue``, and the router running in ``dir``."""

    def __init__(self, d: Path) -> None:
        self.dir, self.port = d, free_port()
        self.endpoint = f"tls/127.0.0.1:{self.port}"
        common = ["--router-host", "127.0.0.1", "--router-host", "localhost", "--listen", self.endpoint]
        cwd = os.getcwd()
        os.chdir(d)                              # relative --out: the configs name relative paths
        try:
            team = ["--team", TEAM, "--uav", "uav1", "--ugv", "ugv1", "--ugv", "ugv2", "--localizer", "loc1",
                    "--operator", "tap", *common, "--out", "secrets"]
            # ugv9 was in the team, then removed: its certificate (same CA) stays valid, the router's ACL forgets it
            assert certs.main([*team, "--ugv", "ugv9"]) == 0
            assert certs.main(team) == 0
            # same team name and vehicle id, another CA: a stranger with a plausible certificate
            assert certs.main(["--team", TEAM, "--ugv", "ugv1", *common, "--out", "rogue"]) == 0
        finally:
            os.chdir(cwd)
        self.log = open(d / "router.log", "wb")
        self.router = _uvteam("router", "--zenoh-config", "secrets/router.json5", cwd=d, log=self.log)
        if not wait_port(self.port):
            _stop(self.router)
            raise RuntimeError("router did not come up:\n" + (d / "router.log").read_text())
        self.sessions: list = []

    def config(self, member: str, folder: str = "secrets", **extra) -> zenoh.Config:
        """A member's generated config, its relative file paths made absolute for this test process, and
        a 10 s connect timeout instead of waiting for ever."""
        c = zenoh.Config.from_file(str(self.dir / folder / f"{member}.json5"))
        c.insert_json5("connect/timeout_ms", "10000")
        tls = json.loads(c.get_json("transport/link/tls"))
        for k in ("root_ca_certificate", "connect_private_key", "connect_certificate"):
            c.insert_json5(f"transport/link/tls/{k}", json.dumps(str(self.dir / tls[k])))
        for k, v in extra.items():
            c.insert_json5(k, v)
        return c

    def open(self, member: str) -> zenoh.Session:
        s = zenoh.open(self.config(member))
        self.sessions.append(s)
        return s

    def close(self) -> None:
        for s in self.sessions:
            s.close()
        _stop(self.router)
        self.log.close()


@pytest.fixture(scope="module")
def team(tmp_path_factory):
    t = Secure(tmp_path_factory.mktemp("secure"))
    yield t
    t.close()


class Inbox:
    """Everything a session receives on the team's keys (data and liveliness), with waiting."""

    def __init__(self, session: zenoh.Session) -> None:
        self.lock = threading.Condition()
        self.data: list[tuple[str, bytes]] = []
        self.alive: list[str] = []
        self.sub = session.declare_subscriber(keys.everything(TEAM), self._on_data)
        self.lsub = session.liveliness().declare_subscriber(keys.alive_all(TEAM), self._on_alive, history=True)

    def _on_data(self, s) -> None:
        with self.lock:
            self.data.append((str(s.key_expr), s.payload.to_bytes()))
            self.lock.notify_all()

    def _on_alive(self, s) -> None:
        with self.lock:
            if s.kind == zenoh.SampleKind.PUT:
                self.alive.append(str(s.key_expr))
            self.lock.notify_all()

    def wait(self, pred, timeout_s: float = 5.0) -> bool:
        with self.lock:
            return self.lock.wait_for(lambda: pred(self), timeout_s)

    def got(self, key: str, payload: bytes) -> bool:
        with self.lock:
            return (key, payload) in self.data

    def close(self) -> None:
        self.sub.undeclare()
        self.lsub.undeclare()


@pytest.fixture
def inbox(team):
    """ugv2's view of the team (it writes nothing in these tests)."""
    box = Inbox(team.open("ugv2"))
    yield box
    box.close()


def _put_until_seen(box: Inbox, session, key: str, timeout_s: float = 5.0) -> bytes:
    """Put markers on ``key`` until one arrives (the subscriber's declaration has propagated)."""
    end, n = time.monotonic() + timeout_s, 0
    while time.monotonic() < end:
        n += 1
        marker = f"marker {n}".encode()
        session.put(key, marker)
        if box.wait(lambda b: b.got(key, marker), 0.25):
            return marker
    raise AssertionError(f"nothing put on {key} arrived in {timeout_s} s")


def _denied(box: Inbox, session, attempts: list[tuple[str, bytes]], marker_key: str) -> list[tuple[str, bytes]]:
    """Put ``attempts`` and then a marker on the allowed ``marker_key``; return the attempts that arrived."""
    _put_until_seen(box, session, marker_key)
    for k, v in attempts:
        session.put(k, v)
    last = b"after the attempts"
    session.put(marker_key, last)
    assert box.wait(lambda b: b.got(marker_key, last)), "the marker after the attempts never arrived"
    time.sleep(0.2)                                      # anything still in flight on another path
    return [a for a in attempts if box.got(*a)]


# --- (a) strangers -------------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "folder, extra",
    [
        ("rogue", {}),                                                     # a certificate from another CA, CN ugv1
        ("secrets", {"transport/link/tls/enable_mtls": "false"}),          # the team CA, but no certificate shown
    ],
)
def test_stranger_is_refused(team, inbox, folder, extra):
    conf = team.config("ugv1", folder, **{"connect/timeout_ms": "2000", **extra})
    if folder == "secrets":
        for k in ("connect_private_key", "connect_certificate"):
            conf.insert_json5(f"transport/link/tls/{k}", "null")
    with pytest.raises(zenoh.ZError):
        s = zenoh.open(conf)
        s.close()
    # and plain TCP to the TLS port is not a way in either
    with pytest.raises(zenoh.ZError):
        s = zenoh.open(zenoh.Config.from_json5(
            f'{{mode:"client", scouting:{{multicast:{{enabled:false}}}}, '
            f'connect:{{endpoints:["tcp/127.0.0.1:{team.port}"], timeout_ms:2000}}}}'))
        s.close()


def test_removed_vehicle_gets_nothing_through(team, inbox):
    """A certificate of the team CA whose id the router's config no longer lists: the TLS session opens,
    but its puts, token and subscriptions are all refused."""
    ugv9, ugv1 = team.open("ugv9"), team.open("ugv1")
    seen = Inbox(ugv9)
    try:
        ugv9.put(keys.key(TEAM, "ugv9", "fix"), b"removed fix")
        tokens = [ugv9.liveliness().declare_token(keys.alive(TEAM, "ugv9")),
                  ugv1.liveliness().declare_token(keys.alive(TEAM, "ugv1"))]
        _put_until_seen(inbox, ugv1, keys.key(TEAM, "ugv1", "fix"))     # ugv1 gets through to ugv2 ...
        assert inbox.wait(lambda b: keys.alive(TEAM, "ugv1") in b.alive)
        time.sleep(0.3)
        assert not inbox.got(keys.key(TEAM, "ugv9", "fix"), b"removed fix")
        assert keys.alive(TEAM, "ugv9") not in inbox.alive
        # ... and nothing to ugv9 (its own put and token come back to it inside its session, not via the router)
        assert [k for k, _ in seen.data if "/ugv9/" not in k] == []
        assert [k for k in seen.alive if "/ugv9/" not in k] == []
        for t in tokens:
            t.undeclare()
    finally:
        seen.close()


# --- (b) a vehicle writes only its own keys --------------------------------------------------------------

def test_vehicle_puts_only_under_its_own_keys(team, inbox):
    ugv1 = team.open("ugv1")
    own = keys.key(TEAM, "ugv1", "fix")
    arrived = _denied(inbox, ugv1, [(keys.key(TEAM, "ugv2", "fix"), b"forged fix"),
                                    (keys.key(TEAM, "ugv2", "plan"), b"forged plan"),
                                    (keys.key(TEAM, "loc1", "status"), b"forged status"),
                                    (f"uvteam/{TEAM}/*/fix", b"wildcard over the team"),
                                    ("uvteam/other/ugv1/fix", b"another team's key")], own)
    assert arrived == []
    assert inbox.got(own, b"after the attempts")                         # its own key works
    # liveliness: its own token shows, a token in another vehicle's name does not
    tokens = [ugv1.liveliness().declare_token(keys.alive(TEAM, "ugv2")),
              ugv1.liveliness().declare_token(keys.alive(TEAM, "ugv1"))]
    assert inbox.wait(lambda b: keys.alive(TEAM, "ugv1") in b.alive)
    time.sleep(0.3)
    assert keys.alive(TEAM, "ugv2") not in inbox.alive
    for t in tokens:
        t.undeclare()


# --- (c) only the localizer puts crowds ------------------------------------------------------------------

def test_only_the_localizer_puts_crowds(team, inbox):
    crowds = keys.key(TEAM, "loc1", "crowds")
    uav1, ugv1, loc1 = team.open("uav1"), team.open("ugv1"), team.open("loc1")
    # the UAV may write its own keys, but no crowds, not under its own id, not even through a wildcard
    arrived = _denied(inbox, uav1, [(keys.key(TEAM, "uav1", "crowds"), b"uav crowds"), (crowds, b"uav as loc1"),
                                    (f"uvteam/{TEAM}/uav1/*", b"uav wildcard"),
                                    (f"uvteam/{TEAM}/uav1/**", b"uav double wildcard")],
                      keys.key(TEAM, "uav1", "fix"))
    assert arrived == []
    assert _denied(inbox, ugv1, [(crowds, b"ugv crowds"), (keys.key(TEAM, "ugv1", "crowds"), b"own crowds")],
                   keys.key(TEAM, "ugv1", "status")) == []
    _put_until_seen(inbox, loc1, crowds)                                # the localizer's do arrive


# --- (d) an operator reads, never writes ---------------------------------------------------------------

def test_operator_subscribes_but_cannot_put(team, inbox):
    tap, ugv1 = team.open("tap"), team.open("ugv1")
    seen = Inbox(tap)
    # beyond the team's keys: refused (own session: within one, data that came for an allowed subscription
    # is handed to every local subscriber it matches)
    everything = []
    wide = team.open("tap").declare_subscriber("uvteam/**", lambda s: everything.append(str(s.key_expr)))
    try:
        _put_until_seen(seen, ugv1, keys.key(TEAM, "ugv1", "fix"))     # it reads the team's keys
        attempts = [(keys.key(TEAM, "tap", "status"), b"tap status"), (keys.key(TEAM, "ugv1", "fix"), b"tap fix")]
        for k, v in attempts:
            tap.put(k, v)
        token = tap.liveliness().declare_token(keys.alive(TEAM, "tap"))
        # ugv1's marker after the operator's attempts: ugv2 sees it, and none of the operator's puts
        _put_until_seen(inbox, ugv1, keys.key(TEAM, "ugv1", "plan"))
        time.sleep(0.3)
        assert [a for a in attempts if inbox.got(*a)] == []
        assert keys.alive(TEAM, "tap") not in inbox.alive
        assert everything == []
        token.undeclare()
    finally:
        wide.undeclare()
        seen.close()


# --- (e) a small team works under the profile ----------------------------------------------------------

def test_small_team_flows_arrive(team):
    """Real uvteam messages through the profile: ugv1 and uav1 publish fixes on their buses, the localizer
    its crowds under the UAV's key, and `uvteam tap` (a separate process with the operator's config, relative
    paths as deployed) prints them."""
    tap = subprocess.Popen([sys.executable, "-m", "uvteam", "tap", "--zenoh-config", "secrets/tap.json5",
                            "--team", TEAM, "--count", "10", "--duration", "20"], cwd=team.dir, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, start_new_session=True)
    buses = {}
    try:
        for v in ("ugv1", "uav1", "loc1"):
            buses[v] = ZenohBus(zenoh.open(team.config(v)))
            buses[v].declare_alive(keys.alive(TEAM, v))
        end = time.monotonic() + 20.0
        while time.monotonic() < end and tap.poll() is None:
            now = time.time()
            for v in ("ugv1", "uav1"):
                buses[v].publish(keys.key(TEAM, v, "fix"), Fix(v, now, 31.485, -111.544, 1300.0, 90.0, 0.5))
            time.sleep(0.1)
        out, err = tap.communicate(timeout=20)
    finally:
        if tap.poll() is None:
            _stop(tap)
        for b in buses.values():
            b.close()
    assert tap.returncode == 0, err
    lines = [json.loads(x) for x in out.splitlines() if x.startswith("{")]
    got = {x["key"] for x in lines}
    assert {keys.key(TEAM, "ugv1", "fix"), keys.key(TEAM, "uav1", "fix")} <= got, (got, err[-2000:])
    assert all(x["lat_deg"] == 31.485 for x in lines if x["key"].endswith("/fix"))


# --- the router honours its config file's endpoints -------------------------------------------------------

def test_router_listens_where_its_config_says(tmp_path):
    port = free_port()
    conf = tmp_path / "router.json5"
    conf.write_text(f'{{mode:"router", scouting:{{multicast:{{enabled:false}}}}, '
                    f'listen:{{endpoints:["tcp/127.0.0.1:{port}"]}}}}')
    with open(tmp_path / "router.log", "wb") as log:
        p = _uvteam("router", "--zenoh-config", str(conf), cwd=tmp_path, log=log)
        try:
            assert wait_port(port), (tmp_path / "router.log").read_text()
            c = zenoh.Config.from_json5(f'{{mode:"client", scouting:{{multicast:{{enabled:false}}}}, '
                                        f'connect:{{endpoints:["tcp/127.0.0.1:{port}"], timeout_ms:3000}}}}')
            with zenoh.open(c) as s:
                assert s.info.routers_zid()                               # a zenoh router answered there
        finally:
            assert _stop(p) in (0, -signal.SIGTERM)
    assert f"listening on tcp/127.0.0.1:{port}" in (tmp_path / "router.log").read_text()


# --- (f) the whole loopback team under the profile --------------------------------------------------------

def test_whole_team_runs_under_the_profile(tmp_path):
    """`uvteam demo --secure`: uvteam certs writes the secrets into the run folder, the router starts from
    its generated config, every process joins with its own certificate, the demo's view as read-only "view"."""
    text = DEFAULT_SCENARIO.read_text().replace("duration_s = 30.0", "duration_s = 10.0")
    sc = tmp_path / "scenario.toml"
    sc.write_text(text)
    team = Team(str(sc), workdir=str(tmp_path / "run"), frames="sensor", secure=True)
    summary, codes = run_demo(team, StopFlag(install=False), live=False, out=open(tmp_path / "view.txt", "w"))
    logs = "\n".join(f"--- {n}\n{team.tail(n)}" for n in codes)
    assert "tls/127.0.0.1" in team.tail("router"), logs
    assert summary["n"] > 40, logs                                    # sensor -> UAV -> localizer -> crowds
    for u in team.ugvs:                                               # the localizer's crowds reach every UGV
        assert summary["metrics"][u]["crowds_received"] > 20, (u, summary["metrics"][u])
    assert summary["rejected"] and all(n == 0 for n in summary["rejected"].values()), summary["rejected"]
    bad = {n: c for n, c in codes.items() if c not in (0, -signal.SIGTERM)}
    assert not bad, logs
