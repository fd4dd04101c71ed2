"""`uvteam protocol`: write the published protocol, generated from the message definitions.

    uvteam protocol --json-schema docs/schemas          one JSON Schema per message, and the envelope
    uvteam protocol --markdown docs/protocol.md         the field tables of the reference (between its markers)
    uvteam protocol --json-schema docs/schemas --markdown docs/protocol.md --check
                                                        exit 1 if the files differ from what the code says

The schemas come from uvteam.messages (field types, the codec's rules by field name, each message's
own rules): see uvteam.protocol.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from uvteam import protocol

BEGIN = "<!-- BEGIN GENERATED: uvteam protocol --markdown; do not edit by hand -->"
END = "<!-- END GENERATED -->"


def with_reference(doc: str) -> str:
    """``doc`` with the text between its markers replaced by the generated reference."""
    if BEGIN not in doc or END not in doc:
        raise ValueError(f"the markdown file has no markers {BEGIN!r} ... {END!r}")
    head, rest = doc.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return f"{head}{BEGIN}\n\n{protocol.markdown_reference()}\n{END}{tail}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam protocol", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json-schema", metavar="DIR", help="write one JSON Schema file per message into DIR")
    ap.add_argument("--markdown", metavar="FILE", help="rewrite the generated part of FILE (docs/protocol.md)")
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 when a file is not up to date")
    args = ap.parse_args(argv)
    if not args.json_schema and not args.markdown:
        ap.error("say what to write: --json-schema DIR and/or --markdown FILE")
    stale: list[str] = []
    if args.json_schema:
        d = Path(args.json_schema)
        want = {name: protocol.dumps(s) for name, s in protocol.all_schemas().items()}
        if args.check:
            have = {p.name for p in d.glob("*.schema.json")} if d.is_dir() else set()
            stale += [str(d / n) for n, text in want.items()
                      if not (d / n).is_file() or (d / n).read_text(encoding="utf-8") != text]
            stale += [str(d / n) + " (no longer a message)" for n in sorted(have - set(want))]
        else:
            d.mkdir(parents=True, exist_ok=True)
            for n, text in want.items():
                (d / n).write_text(text, encoding="utf-8")
            print(f"uvteam protocol: {len(want)} schemas in {d}")
    if args.markdown:
        p = Path(args.markdown)
        try:
            old = p.read_text(encoding="utf-8")
            new = with_reference(old)
        except (OSError, ValueError) as exc:
            print(f"uvteam protocol: {p}: {exc}", file=sys.stderr)
            return 2
        if args.check:
            if new != old:
                stale.append(str(p))
        elif new != old:
            p.write_text(new, encoding="utf-8")
            print(f"uvteam protocol: updated {p}")
    if stale:
        print("uvteam protocol: not up to date (run without --check to regenerate):\n  " + "\n  ".join(stale),
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
