"""`uvteam certs`: the team's certificate authority, one certificate per vehicle, and zenoh configs
that admit only the team (TLS with client certificates) and let each vehicle write only its own keys.

    uvteam certs --team border1 --uav uav1 --ugv ugv1 --ugv ugv2 --localizer loc1 \\
                 --operator laptop1 --router-host 10.0.0.1 --out deploy/secrets/border1
    uvteam certs --from-configs deploy/vehicles --operator laptop1 --router-host 10.0.0.1 \\
                 --out deploy/secrets/border1

Writes into --out (keys 0600, the folder 0700):
    ca.pem               the team CA's certificate; every vehicle and the router trust only it
    ca.key               the team CA's key: keep it on the ground station, never on a vehicle; it is
                         reused when present (a new vehicle joins without re-keying the others)
    router.pem/.key      the router's certificate (CN router, SANs = the --router-host names and IPs)
    router.json5         the router's zenoh config: TLS listen, client certificates required, access control
    <id>.pem/.key        one certificate per vehicle or operator (CN = its id)
    <id>.json5           its zenoh client config: TLS to the router with its own certificate

Access control (zenoh ``access_control`` on the router, default deny; an explicit deny beats an allow):
    every member         may subscribe to and receive ``uvteam/<team>/**`` (data and liveliness)
    a vehicle            may put only under ``uvteam/<team>/<its id>/...`` and declare only its own
                         ``alive`` token
    crowds               only a localizer puts them (under its own id); no other member may put a
                         ``crowds`` key, not even its own
    the simulator        also puts each UAV's ``frame`` and ``sensor`` (its truth is under its own id)
    an operator          (uvteam tap, a map) reads only: no put, no token
Denied messages are dropped silently by the router; the publisher sees no error. A certificate of the
team CA whose id is not in the list (a vehicle since removed: run this again without it) still opens
a session but gets nothing through: the router's config no longer names it.

The file paths inside the JSON5 configs are written as --out was given (zenoh opens them relative to
the service's working directory: /opt/uvteam under the shipped systemd units, so run this from the
checkout's root); --files-at writes another prefix, e.g. where the files will sit on the vehicles.
"""

from __future__ import annotations

import argparse
import datetime as dt
import ipaddress
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

from uvteam import keys
from uvteam.errors import ConfigError

__all__ = ["Roster", "access_control", "client_config", "router_config", "roster_from_configs",
           "make_ca", "issue", "write_team", "main"]

ROUTER_CN = "router"
RESERVED_IDS = frozenset({ROUTER_CN, "ca"})     # file names in --out
DEFAULT_PORT = 7447
CA_DAYS = 3650
LEAF_DAYS = 825
CLOCK_SKEW = dt.timedelta(hours=1)               # certificates are valid from an hour ago
LEASE_MS = 3000                                  # as deploy/zenoh/*.json5: a silent link is dead after ~3 s
WRITE = ["put", "delete"]
# What the router sends a member: data, subscriber declarations (so its publishers know they are matched)
# and liveliness tokens of the others.
DELIVER = ["put", "delete", "declare_subscriber", "liveliness_token"]
# What a member may ask for: subscriptions to data and to liveliness, and the liveliness history.
READ = ["declare_subscriber", "declare_liveliness_subscriber", "liveliness_query"]


@dataclass(frozen=True)
class Roster:
    """Who is in the team, by role. Each id is a certificate's common name and the ``<vehicle>`` chunk
    of the keys that member writes."""

    team: str
    uavs: tuple[str, ...] = ()
    ugvs: tuple[str, ...] = ()
    localizers: tuple[tuple[str, str], ...] = ()     # (localizer id, the UAV whose crowds it publishes)
    simulators: tuple[str, ...] = ()
    operators: tuple[str, ...] = ()                  # read-only: uvteam tap, a map on a laptop
    members: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        keys.check_id("team", self.team)
        ids = [*self.uavs, *self.ugvs, *(loc for loc, _ in self.localizers), *self.simulators, *self.operators]
        for i in ids:
            keys.check_id("vehicle", i)
            if i in RESERVED_IDS:
                raise ConfigError("<ids>", "vehicle", f"{i!r} is reserved (a file of its own in --out)")
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ConfigError("<ids>", "vehicle", f"listed more than once: {', '.join(dup)}")
        if not ids:
            raise ConfigError("<ids>", "vehicle", "the team has no members")
        for loc, uav in self.localizers:
            if uav not in self.uavs:
                raise ConfigError("<ids>", f"localizer {loc}", f"its UAV {uav!r} is not a listed UAV")
        object.__setattr__(self, "members", tuple(ids))

    @property
    def writers(self) -> tuple[str, ...]:
        """Members that publish (everyone but the operators)."""
        return tuple(i for i in self.members if i not in self.operators)


def _own_writes(r: Roster, vid: str) -> list[str]:
    """The keys ``vid`` may put: all of its own if it is a localizer, else all but ``crowds``.

    zenoh allows a put when an allow rule's key expression *includes* the put's key expression, and
    denies it when a deny rule's includes it. A put on a wildcard such as ``uvteam/t/uav1/*`` is
    included in ``uvteam/t/uav1/**`` but not in ``uvteam/t/uav1/crowds``, so "own keys minus crowds"
    is spelled topic by topic: an allow of ``**`` plus a deny of ``crowds`` would let that wildcard
    put reach the crowds subscribers.
    """
    if vid in {loc for loc, _ in r.localizers}:
        return [f"{keys.ROOT}/{r.team}/{vid}/**"]
    return [keys.key(r.team, vid, t) for t in keys.TOPICS if t != "crowds"]


def access_control(r: Roster) -> dict:
    """The router's zenoh ``access_control`` block for the team (see the module docstring)."""
    team_keys = keys.everything(r.team)
    # Ids hold a ':', which no member id can (keys.check_id), so they never clash with a member's.
    rules = [
        {"id": "team: read", "permission": "allow", "flows": ["ingress"], "messages": READ,
         "key_exprs": [team_keys]},
        {"id": "team: deliver", "permission": "allow", "flows": ["egress"], "messages": DELIVER,
         "key_exprs": [team_keys]},
    ]
    subjects = [{"id": "team: members", "cert_common_names": list(r.members)}]
    policies = [{"id": "team: members", "rules": ["team: read", "team: deliver"], "subjects": ["team: members"]}]
    localizers = {loc for loc, _ in r.localizers}
    for vid in r.writers:
        writes = _own_writes(r, vid)
        if vid in r.simulators:
            writes += [keys.key(r.team, uav, t) for uav in r.uavs for t in ("frame", "sensor")]
        mine = [f"{vid}: writes", f"{vid}: alive"]
        rules += [{"id": mine[0], "permission": "allow", "flows": ["ingress"], "messages": WRITE, "key_exprs": writes},
                  {"id": mine[1], "permission": "allow", "flows": ["ingress"], "messages": ["liveliness_token"],
                   "key_exprs": [keys.alive(r.team, vid)]}]
        if vid not in localizers:
            mine.append(f"{vid}: no crowds")   # not needed with the topic-by-topic allow; it states the intent
            rules.append({"id": mine[2], "permission": "deny", "flows": ["ingress"], "messages": WRITE,
                          "key_exprs": [keys.key(r.team, vid, "crowds")]})
        subjects.append({"id": vid, "cert_common_names": [vid]})
        policies.append({"id": vid, "rules": mine, "subjects": [vid]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies}


def _tls_common(ca: str) -> dict:
    return {"root_ca_certificate": ca, "enable_mtls": True}


def client_config(connect: list[str], ca: str, cert: str, key: str) -> dict:
    """A member's zenoh config: client of the router over TLS, presenting its own certificate."""
    return {
        "mode": "client",
        "connect": {"endpoints": list(connect), "timeout_ms": -1,      # wait for the router at start-up
                    "retry": {"period_init_ms": 250, "period_max_ms": 1000, "period_increase_factor": 2}},
        "scouting": {"multicast": {"enabled": False}},
        "transport": {"link": {"tx": {"lease": LEASE_MS},
                               "tls": {**_tls_common(ca), "connect_private_key": key, "connect_certificate": cert}}},
    }


def router_config(listen: list[str], ca: str, cert: str, key: str, acl: dict) -> dict:
    """The router's zenoh config: TLS listen only, client certificates from the team CA required, ACL."""
    return {
        "mode": "router",
        "listen": {"endpoints": list(listen)},
        "scouting": {"multicast": {"enabled": False}},
        "transport": {"link": {"tx": {"lease": LEASE_MS},
                               "tls": {**_tls_common(ca), "listen_private_key": key, "listen_certificate": cert}}},
        "access_control": acl,
    }


# --- certificates -------------------------------------------------------------------------------------

def _name(cn: str, team: str):
    from cryptography import x509  # noqa: PLC0415
    from cryptography.x509.oid import NameOID  # noqa: PLC0415

    return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, f"uvteam {team}"),
                      x509.NameAttribute(NameOID.COMMON_NAME, cn)])


def _san(host: str):
    from cryptography import x509  # noqa: PLC0415

    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        return x509.DNSName(host)


def make_ca(team: str, *, days: int = CA_DAYS, now: dt.datetime | None = None):
    """A new team CA: (EC P-256 private key, self-signed certificate with basicConstraints CA:TRUE)."""
    from cryptography import x509  # noqa: PLC0415
    from cryptography.hazmat.primitives import hashes  # noqa: PLC0415
    from cryptography.hazmat.primitives.asymmetric import ec  # noqa: PLC0415

    now = now or dt.datetime.now(dt.timezone.utc)
    key = ec.generate_private_key(ec.SECP256R1())
    name = _name(f"uvteam {team} CA", team)
    cert = (x509.CertificateBuilder().subject_name(name).issuer_name(name).public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - CLOCK_SKEW).not_valid_after(now + dt.timedelta(days=days))
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(x509.KeyUsage(digital_signature=True, content_commitment=False, key_encipherment=False,
                                         data_encipherment=False, key_agreement=False, key_cert_sign=True,
                                         crl_sign=True, encipher_only=False, decipher_only=False), critical=True)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
            .sign(key, hashes.SHA256()))
    return key, cert


def issue(ca_key, ca_cert, cn: str, team: str, *, hosts: tuple[str, ...] = (), days: int = LEAF_DAYS,
          now: dt.datetime | None = None):
    """A leaf certificate signed by the CA: (EC P-256 key, certificate with CN ``cn``, EKU serverAuth +
    clientAuth, and SANs for ``hosts`` (DNS names or IP addresses) when given)."""
    from cryptography import x509  # noqa: PLC0415
    from cryptography.hazmat.primitives import hashes  # noqa: PLC0415
    from cryptography.hazmat.primitives.asymmetric import ec  # noqa: PLC0415
    from cryptography.x509.oid import ExtendedKeyUsageOID  # noqa: PLC0415

    now = now or dt.datetime.now(dt.timezone.utc)
    key = ec.generate_private_key(ec.SECP256R1())
    b = (x509.CertificateBuilder().subject_name(_name(cn, team)).issuer_name(ca_cert.subject)
         .public_key(key.public_key()).serial_number(x509.random_serial_number())
         .not_valid_before(now - CLOCK_SKEW)
         .not_valid_after(min(now + dt.timedelta(days=days), ca_cert.not_valid_after_utc))
         .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
         .add_extension(x509.KeyUsage(digital_signature=True, content_commitment=False, key_encipherment=False,
                                      data_encipherment=False, key_agreement=False, key_cert_sign=False,
                                      crl_sign=False, encipher_only=False, decipher_only=False), critical=True)
         .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
                        critical=False)
         .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
         .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()), critical=False))
    if hosts:
        b = b.add_extension(x509.SubjectAlternativeName([_san(h) for h in hosts]), critical=False)
    return key, b.sign(ca_key, hashes.SHA256())


def _key_pem(key) -> bytes:
    from cryptography.hazmat.primitives import serialization  # noqa: PLC0415

    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())


def _cert_pem(cert) -> bytes:
    from cryptography.hazmat.primitives import serialization  # noqa: PLC0415

    return cert.public_bytes(serialization.Encoding.PEM)


def _write_secret(path: Path, data: bytes) -> None:
    """Write a private key readable by its owner only (0600), also when the file already exists."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.fchmod(fd, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)


def _write_public(path: Path, data: bytes) -> None:
    path.write_bytes(data)
    path.chmod(0o644)


def to_json5(value, indent: int = 0) -> str:
    """JSON5 as the shipped templates write it: bare keys, lists of plain values on one line,
    trailing commas. zenoh reads it; so would any JSON5 parser."""
    pad, inner = "  " * indent, "  " * (indent + 1)
    if isinstance(value, dict):
        body = "".join(f"{inner}{k}: {to_json5(v, indent + 1)},\n" for k, v in value.items())
        return "{\n" + body + pad + "}"
    if isinstance(value, list) and any(isinstance(v, (dict, list)) for v in value):
        return "[\n" + "".join(f"{inner}{to_json5(v, indent + 1)},\n" for v in value) + pad + "]"
    return json.dumps(value)


def _write_json5(path: Path, header: str, conf: dict) -> None:
    _write_public(path, (f"// {header}\n// Written by `uvteam certs`; regenerate rather than edit.\n"
                         + to_json5(conf) + "\n").encode())


def _load_or_make_ca(out: Path, team: str, new: bool, days: int):
    from cryptography import x509  # noqa: PLC0415
    from cryptography.hazmat.primitives import serialization  # noqa: PLC0415
    from cryptography.x509.oid import NameOID  # noqa: PLC0415

    cert_p, key_p = out / "ca.pem", out / "ca.key"
    if not new and cert_p.is_file() and key_p.is_file():
        cert = x509.load_pem_x509_certificate(cert_p.read_bytes())
        key = serialization.load_pem_private_key(key_p.read_bytes(), password=None)
        cn = cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value
        if cn != f"uvteam {team} CA":
            raise ConfigError(str(cert_p), "CN", f"is {cn!r}, not team {team!r}'s CA (another --out, or --new-ca)")
        return key, cert, False
    key, cert = make_ca(team, days=days)
    _write_secret(key_p, _key_pem(key))
    _write_public(cert_p, _cert_pem(cert))
    return key, cert, True


def write_team(r: Roster, out: str | Path, *, router_hosts: tuple[str, ...], listen: tuple[str, ...] = (),
               connect: tuple[str, ...] = (), port: int | None = None, files_at: str | None = None,
               new_ca: bool = False, days: int = LEAF_DAYS) -> dict:
    """Write the CA (or reuse the one in ``out``), every member's and the router's certificate and key,
    and their zenoh configs. Returns what was written: {"ca_created": bool, "files": [paths]}."""
    if not router_hosts:
        raise ConfigError("--router-host", "router_host", "give at least one name or IP of the router")
    out = Path(out)
    out.mkdir(mode=0o700, parents=True, exist_ok=True)
    prefix = str(out) if files_at is None else files_at

    def at(name: str) -> str:
        return name if prefix in ("", ".") else f"{prefix.rstrip('/')}/{name}"

    def host_ep(h: str) -> str:
        return f"tls/[{h}]:{port}" if ":" in h else f"tls/{h}:{port}"

    for ep in (*listen, *connect):
        if not ep.startswith("tls/"):
            raise ConfigError("--listen/--connect", "endpoint", f"must be a tls/ endpoint, got {ep!r}")
    if port is None:                     # the router's first listen port, else the default
        try:
            port = int(listen[0].rsplit(":", 1)[1]) if listen else DEFAULT_PORT
        except ValueError:
            raise ConfigError("--listen", "endpoint", f"no port in {listen[0]!r}") from None
    listen = listen or (f"tls/0.0.0.0:{port}",)
    connect = connect or (host_ep(router_hosts[0]),)
    ca_key, ca_cert, created = _load_or_make_ca(out, r.team, new_ca, CA_DAYS)
    files = [out / "ca.pem", out / "ca.key"]
    for cn, hosts in [(ROUTER_CN, tuple(router_hosts))] + [(m, ()) for m in r.members]:
        key, cert = issue(ca_key, ca_cert, cn, r.team, hosts=hosts, days=days)
        _write_secret(out / f"{cn}.key", _key_pem(key))
        _write_public(out / f"{cn}.pem", _cert_pem(cert))
        files += [out / f"{cn}.pem", out / f"{cn}.key"]
    ca = at("ca.pem")
    _write_json5(out / "router.json5",
                 f"Team {r.team}'s router: `uvteam router --zenoh-config {at('router.json5')}`",
                 router_config(list(listen), ca, at("router.pem"), at("router.key"), access_control(r)))
    files.append(out / "router.json5")
    for m in r.members:
        _write_json5(out / f"{m}.json5",
                     f"{m} of team {r.team}: [bus] zenoh_config, or --zenoh-config {at(m + '.json5')}",
                     client_config(list(connect), ca, at(f"{m}.pem"), at(f"{m}.key")))
        files.append(out / f"{m}.json5")
    return {"ca_created": created, "files": [str(f) for f in files]}


def roster_from_configs(folder: str | Path, *, team: str | None = None) -> Roster:
    """The team's members from its vehicle TOMLs (``deploy/vehicles/*.toml``): UAVs, UGVs, localizers."""
    from uvteam.io.files import load_vehicle_config  # noqa: PLC0415

    paths = sorted(Path(folder).glob("*.toml"))
    if not paths:
        raise ConfigError(str(folder), "<files>", "no *.toml vehicle configs here")
    by_role: dict[str, list] = {"uav": [], "ugv": [], "localizer": []}
    for p in paths:
        cfg = load_vehicle_config(p)
        if team is not None and cfg.team != team:
            raise ConfigError(str(p), "vehicle.team", f"is {cfg.team!r}, expected {team!r}")
        team = cfg.team
        by_role[cfg.role].append((cfg.id, cfg.localizer.uav) if cfg.role == "localizer" else cfg.id)
    return Roster(team, tuple(by_role["uav"]), tuple(by_role["ugv"]), tuple(by_role["localizer"]))


def _localizer_arg(text: str, uavs: list[str]) -> tuple[str, str]:
    loc, _, uav = text.partition(":")
    if not uav:
        if len(uavs) != 1:
            raise ConfigError("--localizer", loc, f"say whose crowds it publishes (--localizer {loc}:UAV): "
                              f"{len(uavs)} UAVs are listed")
        uav = uavs[0]
    return loc, uav


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam certs", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    g = ap.add_argument_group("the team (ids are certificate common names and key chunks)")
    g.add_argument("--team", help="team id (the uvteam/<team>/... key chunk); required without --from-configs")
    g.add_argument("--from-configs", metavar="DIR", help="read team, UAVs, UGVs and localizers from DIR/*.toml")
    g.add_argument("--uav", action="append", default=[], metavar="ID")
    g.add_argument("--ugv", action="append", default=[], metavar="ID")
    g.add_argument("--localizer", action="append", default=[], metavar="ID[:UAV]",
                   help="a localizer and the UAV whose crowds it publishes (default: the only UAV)")
    g.add_argument("--simulator", action="append", default=[], metavar="ID",
                   help="the simulator (uvteam sim publishes as 'sim'): may put every UAV's frame and sensor")
    g.add_argument("--operator", action="append", default=[], metavar="ID",
                   help="a read-only member: uvteam tap or a map on a laptop (e.g. tap, map, laptop1)")
    g = ap.add_argument_group("the router")
    g.add_argument("--router-host", action="append", default=[], metavar="HOST", required=True,
                   help="a DNS name or IP the vehicles reach the router by (repeatable; all go in its "
                        "certificate, the first in the vehicles' connect endpoint)")
    g.add_argument("--port", type=int, default=None,
                   help=f"TLS port (default: the first --listen endpoint's, else {DEFAULT_PORT})")
    g.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                   help="the router's listen endpoint (default tls/0.0.0.0:PORT)")
    g.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="the members' connect endpoint (default tls/<first --router-host>:PORT)")
    g = ap.add_argument_group("output")
    g.add_argument("--out", required=True, metavar="DIR", help="where to write (e.g. deploy/secrets/<team>)")
    g.add_argument("--files-at", metavar="PREFIX", help="the folder the configs name for the certificate "
                   "files (default: --out as given, relative to the services' working directory)")
    g.add_argument("--days", type=int, default=LEAF_DAYS, help="certificate lifetime (default %(default)s)")
    g.add_argument("--new-ca", action="store_true", help="make a new CA even if --out has one (re-keys everyone)")
    args = ap.parse_args(argv)
    try:
        base = roster_from_configs(args.from_configs, team=args.team) if args.from_configs else None
        team = base.team if base else args.team
        if not team:
            raise ConfigError("--team", "team", "give --team or --from-configs")
        uavs = [*(base.uavs if base else ()), *args.uav]
        roster = Roster(team, tuple(uavs), (*(base.ugvs if base else ()), *args.ugv),
                        (*(base.localizers if base else ()), *(_localizer_arg(x, uavs) for x in args.localizer)),
                        tuple(args.simulator), tuple(args.operator))
        done = write_team(roster, args.out, router_hosts=tuple(args.router_host), listen=tuple(args.listen),
                          connect=tuple(args.connect), port=args.port, files_at=args.files_at,
                          new_ca=args.new_ca, days=args.days)
    except ConfigError as exc:
        print(f"uvteam certs: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    print(f"uvteam certs: team {roster.team}: {'new' if done['ca_created'] else 'existing'} CA, "
          f"certificates for router, {', '.join(roster.members)} in {out}")
    print(f"  router:   uvteam router --zenoh-config {out / 'router.json5'}")
    print("  vehicles: copy ca.pem, <id>.pem, <id>.key, <id>.json5; [bus] zenoh_config = <id>.json5")
    print(f"  keep {out / 'ca.key'} off the vehicles")
    return 0
