"""`uvteam certs` without the network: the roster, the access-control block, the certificates and files."""

import json
import stat
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from uvteam.errors import ConfigError
from uvteam_ground import certs

REPO = Path(__file__).resolve().parents[2]
TEAM = certs.Roster("t1", uavs=("uav1",), ugvs=("ugv1", "ugv2"), localizers=(("loc1", "uav1"),),
                    simulators=("sim",), operators=("tap", "map"))


@pytest.mark.parametrize(
    "kw, key",
    [
        (dict(team="t 1", ugvs=("ugv1",)), "team"),                              # bad team id
        (dict(team="t1", ugvs=("ugv/1",)), "vehicle"),                           # would inject key syntax
        (dict(team="t1", ugvs=("ugv1",), operators=("ugv1",)), "vehicle"),       # one id, two roles
        (dict(team="t1", ugvs=("router",)), "vehicle"),                          # clashes with router.pem
        (dict(team="t1", ugvs=("ca",)), "vehicle"),                              # clashes with ca.key
        (dict(team="t1"), "vehicle"),                                            # nobody
        (dict(team="t1", uavs=("uav1",), localizers=(("loc1", "uav2"),)), "localizer loc1"),  # unknown UAV
    ],
)
def test_bad_roster(kw, key):
    with pytest.raises(ConfigError) as e:
        certs.Roster(**kw)
    assert e.value.key == key


def _rules_of(acl, cn):
    """{rule id: rule} of every policy whose subjects take the certificate common name ``cn``."""
    by_id = {r["id"]: r for r in acl["rules"]}
    subjects = {s["id"] for s in acl["subjects"] if cn in s["cert_common_names"]}
    return {rid: by_id[rid] for p in acl["policies"] if subjects & set(p["subjects"]) for rid in p["rules"]}


def test_acl_default_deny_and_each_member_writes_only_its_own():
    acl = certs.access_control(TEAM)
    assert acl["enabled"] is True and acl["default_permission"] == "deny"
    members = next(s for s in acl["subjects"] if s["id"] == "team: members")["cert_common_names"]
    assert sorted(members) == sorted(["uav1", "ugv1", "ugv2", "loc1", "sim", "tap", "map"])
    ids = [r["id"] for r in acl["rules"]] + [s["id"] for s in acl["subjects"]]
    assert len({r["id"] for r in acl["rules"]}) == len(acl["rules"]) and ids
    writes = {}
    for s in ("uav1", "ugv1", "ugv2", "loc1", "sim"):
        rules = _rules_of(acl, s)
        put = [k for r in rules.values() if r["permission"] == "allow" and "put" in r["messages"]
               and r["flows"] == ["ingress"] for k in r["key_exprs"]]
        writes[s] = sorted(put)
        tokens = [k for r in rules.values() if "liveliness_token" in r["messages"] and r["flows"] == ["ingress"]
                  for k in r["key_exprs"]]
        assert tokens == [f"uvteam/t1/{s}/alive"], s
    # the localizer: everything under its own id (its crowds among them), nothing else
    assert writes["loc1"] == ["uvteam/t1/loc1/**"]
    # a UGV and the UAV: their own topics one by one, crowds not among them (a wildcard put must not
    # reach crowds subscribers), and a deny stating it
    for v in ("ugv1", "uav1"):
        assert f"uvteam/t1/{v}/fix" in writes[v] and f"uvteam/t1/{v}/status" in writes[v]
        assert not any(k.endswith(("/crowds", "**")) for k in writes[v]) and all(f"/{v}/" in k for k in writes[v])
        deny = [r for r in _rules_of(acl, v).values() if r["permission"] == "deny"]
        assert [r["key_exprs"] for r in deny] == [[f"uvteam/t1/{v}/crowds"]]
    # the simulator: its own topics but crowds (truth), the UAV's frame and sensor
    assert "uvteam/t1/sim/truth" in writes["sim"] and "uvteam/t1/sim/crowds" not in writes["sim"]
    assert {"uvteam/t1/uav1/frame", "uvteam/t1/uav1/sensor"} <= set(writes["sim"])
    # operators: only the team-wide read and deliver rules
    for op in ("tap", "map"):
        assert set(_rules_of(acl, op)) == {"team: read", "team: deliver"}
    assert set(_rules_of(acl, "ugv1")) == {"team: read", "team: deliver", "ugv1: writes", "ugv1: alive",
                                           "ugv1: no crowds"}
    read = _rules_of(acl, "tap")["team: read"]
    assert read["flows"] == ["ingress"] and "put" not in read["messages"] and read["key_exprs"] == ["uvteam/t1/**"]


def test_acl_loads_in_zenoh():
    import zenoh

    conf = certs.router_config(["tls/127.0.0.1:7447"], "ca.pem", "r.pem", "r.key", certs.access_control(TEAM))
    z = zenoh.Config.from_json5(certs.to_json5(conf))        # zenoh rejects unknown fields and bad messages
    assert json.loads(z.get_json("access_control"))["default_permission"] == "deny"
    assert json.loads(z.get_json("transport/link/tls/enable_mtls")) is True


def _cert(p):
    return x509.load_pem_x509_certificate(Path(p).read_bytes())


def test_write_team_certificates_keys_and_configs(tmp_path):
    out = tmp_path / "s"
    done = certs.write_team(TEAM, out, router_hosts=("10.0.0.1", "ground.local"))
    assert done["ca_created"]
    ca = _cert(out / "ca.pem")
    bc = ca.extensions.get_extension_for_class(x509.BasicConstraints)
    assert bc.critical and bc.value.ca
    assert isinstance(ca.public_key(), ec.EllipticCurvePublicKey) and ca.public_key().curve.name == "secp256r1"
    for cn in ("router", *TEAM.members):
        c = _cert(out / f"{cn}.pem")
        assert c.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value == cn
        c.verify_directly_issued_by(ca)                                      # signed by the team CA
        assert not c.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
        eku = c.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
        assert set(eku) == {ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH}
        key = serialization.load_pem_private_key((out / f"{cn}.key").read_bytes(), None)
        assert key.public_key() == c.public_key() and key.curve.name == "secp256r1"
        assert stat.S_IMODE((out / f"{cn}.key").stat().st_mode) == 0o600
        assert (out / f"{cn}.json5").is_file() or cn == "router"
    san = _cert(out / "router.pem").extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert [str(i) for i in san.get_values_for_type(x509.IPAddress)] == ["10.0.0.1"]
    assert san.get_values_for_type(x509.DNSName) == ["ground.local"]
    assert stat.S_IMODE((out / "ca.key").stat().st_mode) == 0o600
    assert stat.S_IMODE(out.stat().st_mode) == 0o700
    import zenoh

    ugv = zenoh.Config.from_file(str(out / "ugv1.json5"))
    assert json.loads(ugv.get_json("connect/endpoints")) == ["tls/10.0.0.1:7447"]
    tls = json.loads(ugv.get_json("transport/link/tls"))
    assert (tls["connect_certificate"], tls["connect_private_key"], tls["root_ca_certificate"]) == (
        f"{out}/ugv1.pem", f"{out}/ugv1.key", f"{out}/ca.pem")
    router = zenoh.Config.from_file(str(out / "router.json5"))
    assert json.loads(router.get_json("listen/endpoints")) == ["tls/0.0.0.0:7447"]
    assert json.loads(router.get_json("access_control"))["enabled"] is True


def test_rerun_keeps_the_ca_and_refuses_another_teams(tmp_path):
    out = tmp_path / "s"
    certs.write_team(TEAM, out, router_hosts=("10.0.0.1",))
    first = (out / "ca.pem").read_bytes()
    bigger = certs.Roster("t1", uavs=("uav1",), ugvs=("ugv1", "ugv2", "ugv3"), localizers=(("loc1", "uav1"),))
    assert not certs.write_team(bigger, out, router_hosts=("10.0.0.1",))["ca_created"]
    assert (out / "ca.pem").read_bytes() == first
    _cert(out / "ugv3.pem").verify_directly_issued_by(_cert(out / "ca.pem"))
    with pytest.raises(ConfigError):
        certs.write_team(certs.Roster("t2", ugvs=("ugv1",)), out, router_hosts=("10.0.0.1",))
    assert certs.write_team(certs.Roster("t2", ugvs=("ugv1",)), out, router_hosts=("h",), new_ca=True)["ca_created"]


def test_cli_from_configs_and_files_at(tmp_path, capsys):
    out = tmp_path / "s"
    rc = certs.main(["--from-configs", str(REPO / "deploy" / "vehicles"), "--operator", "tap",
                     "--router-host", "10.0.0.1", "--out", str(out), "--files-at", "deploy/secrets/border1"])
    assert rc == 0, capsys.readouterr().err
    # the shipped vehicle configs: team border1, uav1, ugv1 and loc1 (which localizes for uav1)
    assert sorted(p.stem for p in out.glob("*.json5")) == ["loc1", "router", "tap", "uav1", "ugv1"]
    assert 'connect_certificate: "deploy/secrets/border1/ugv1.pem"' in (out / "ugv1.json5").read_text()
    assert '"uvteam/border1/loc1/**"' in (out / "router.json5").read_text()


@pytest.mark.parametrize(
    "argv, err",
    [
        (["--ugv", "u1", "--router-host", "h"], "--team"),                                       # no team
        (["--team", "t", "--uav", "a", "--uav", "b", "--localizer", "l", "--router-host", "h"], "localizer"),  # whose?
        (["--team", "t", "--ugv", "u1", "--router-host", "h", "--connect", "tcp/h:1"], "tls/"),   # plain TCP
    ],
)
def test_cli_errors(tmp_path, capsys, argv, err):
    assert certs.main([*argv, "--out", str(tmp_path / "s")]) == 2
    assert err in capsys.readouterr().err


def test_shipped_secure_templates_match_the_generator(tmp_path):
    """deploy/zenoh/*-tls.json5 are what `uvteam certs` writes for the shipped vehicle configs."""
    import zenoh

    out = tmp_path / "s"
    assert certs.main(["--from-configs", str(REPO / "deploy" / "vehicles"), "--operator", "tap", "--operator", "map",
                       "--router-host", "10.0.0.1", "--out", str(out), "--files-at", "deploy/secrets/border1"]) == 0
    for made, shipped in (("router", "router-tls"), ("ugv1", "client-tls")):
        a = zenoh.Config.from_file(str(out / f"{made}.json5"))
        b = zenoh.Config.from_file(str(REPO / "deploy" / "zenoh" / f"{shipped}.json5"))
        for k in ("mode", "listen/endpoints", "connect/endpoints", "transport", "access_control"):
            assert json.loads(a.get_json(k)) == json.loads(b.get_json(k)), (shipped, k)
