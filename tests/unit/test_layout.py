"""The layout shows the architecture: the README's module table names every module of the core, the
pure core imports no I/O adapter, and services never import each other."""

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CORE = REPO / "shared" / "uvteam"


def _modules():
    for p in sorted(CORE.rglob("*.py")):
        rel = p.relative_to(CORE).with_suffix("").as_posix()
        if rel.endswith("__init__") or rel == "__main__" or rel.startswith("formats/"):
            continue
        yield rel, p


def test_the_readme_names_every_core_module():
    text = (REPO / "README.md").read_text()
    named = set(re.findall(r"`([a-z_/]+)`", text))
    missing = [rel for rel, _ in _modules() if rel not in named]
    assert not missing, f"README module table lacks {missing}"


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = ("." * node.level) + (node.module or "")
            out.add(base)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


# core modules that are shells, not pure: the service skeleton, the command line, and the replay of a
# recording file through a localizer (a tool reading files)
SHELLS = {"service", "cli", "replay"}


def test_the_pure_core_touches_no_io():
    io_names = ("zenoh", "pymavlink.mavutil", "serial", "socket", "subprocess")
    for rel, p in _modules():
        if rel.startswith("io/") or rel in SHELLS:
            continue
        imps = _imports(p)
        bad = [i for i in imps if i.split(".")[0] in io_names or (i.startswith(".") and i.lstrip(".").split(".")[0] in ("io", *SHELLS))]
        assert not bad, (rel, bad)


def test_services_never_import_each_other():
    services = [d.name for d in (REPO / "services").iterdir() if d.is_dir() and d.name.startswith("uvteam_")]
    for d in services:
        for p in (REPO / "services" / d).rglob("*.py"):
            others = [i for i in _imports(p) if i.split(".")[0] in services and i.split(".")[0] != d]
            assert not others, (p, others)
