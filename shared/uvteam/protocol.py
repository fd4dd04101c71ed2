"""The wire protocol, published: one JSON Schema per message, generated from :mod:`uvteam.messages`.

Nothing here is written twice. The schemas come from walking the message dataclasses: their field
types (``float``, ``int``, ``str``, ``bytes``, ``X | None``, ``tuple[X, ...]``, ``dict[str, X]``,
arrays annotated with :class:`uvteam.blobs.Columns`, nested dataclasses), the rules the codec applies
by field name (:func:`uvteam.messages.field_range` for ``*lat_deg``/``*lon_deg``/headings/stamps/
accuracies, the id pattern for ``vehicle``/``uav``, the length limits), and each message's own
``_rules`` read from its source: ``self.f in NAME`` becomes an ``enum``, a comparison of ``self.f``
with constants becomes bounds, ``len(self.f) <= N`` becomes ``maxItems``. Rules that JSON Schema
cannot state (parallel lists of one length, a box with x0 <= x1, unique crowd ids) are listed under
``x-rules`` with the codec's own words. Descriptions are the classes' docstrings and the fields'
trailing comments.

One schema validates a message's map in both of its forms: the msgpack ``data`` map on the wire
(``{"schema": "crowds/3", "data": {...}}``) and :func:`uvteam.messages.as_dict`'s flat form (where
``schema`` sits beside the fields; it is optional in the schema for that reason). JSON has no bytes:
``bytes`` fields (a frame's pixels) are msgpack ``bin`` on the wire and base64 text in JSON
(:func:`to_json`).

    write_schemas("docs/schemas")             # what `uvteam protocol --json-schema docs/schemas` does
    json_schema(Crowds)["properties"]["crowds"]
"""

from __future__ import annotations

import ast
import base64
import inspect
import io
import json
import textwrap
import tokenize
import types
import typing
from dataclasses import MISSING, fields, is_dataclass
from functools import cache
from pathlib import Path
from typing import Annotated, Any

import numpy as np

from . import messages
from .blobs import Columns
from .vocab import ID_PATTERN

__all__ = ["TOP_LEVEL", "DIALECT", "json_schema", "wire_schema", "envelope_schema", "schema_id", "file_name", "all_schemas",
           "write_schemas", "to_json", "markdown_reference", "field_rows"]

DIALECT = "https://json-schema.org/draft/2020-12/schema"
# the messages that travel on a key of their own (the others are parts of these)
TOP_LEVEL = tuple(dict.fromkeys(messages.BY_TOPIC.values()))
ID_FIELDS = messages.ID_FIELDS
# The id pattern as JSON Schema (ECMA-262) reads it. "(?!\n)" changes nothing there, where "$" is the end;
# validators that use Python's re (jsonschema) would otherwise let "$" match before a final newline.
ID_JSON_PATTERN = ID_PATTERN.pattern + r"(?!\n)"


def schema_id(cls: type) -> str:
    return f"urn:uvteam:schema:{cls.SCHEMA}"


def file_name(cls: type) -> str:
    return cls.SCHEMA.replace("/", "-") + ".schema.json"


def _def_name(cls: type) -> str:
    return cls.SCHEMA.split("/")[0]


# --- reading the source: field comments and rules -------------------------------------------------
@cache
def _class_source(cls: type) -> tuple[ast.ClassDef, dict[int, str], str]:
    src, _first = inspect.getsourcelines(cls)
    text = textwrap.dedent("".join(src))
    tree = ast.parse(text).body[0]
    comments: dict[int, str] = {}
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.COMMENT:
            comments[tok.start[0]] = tok.string.lstrip("#").strip()
    return tree, comments, text


def _source(text: str, node: ast.AST) -> str:
    """A node's own source text, on one line (ast.unparse would differ between Python versions)."""
    seg = ast.get_source_segment(text, node)
    return " ".join(seg.split()) if seg else ast.unparse(node)


def field_comments(cls: type) -> dict[str, str]:
    """Field name -> the comment on its line (and on the comment-only lines that follow it)."""
    try:
        tree, comments, _ = _class_source(cls)
    except (OSError, TypeError):
        return {}
    out = {}
    for node in tree.body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.lineno in comments:
            out[node.target.id] = comments[node.lineno]
    return out


def _const(node: ast.AST, env: dict) -> Any:
    """A constant expression's value in the messages module (numbers, names of constants), else raises."""
    return eval(compile(ast.Expression(node), "<rule>", "eval"), dict(env), {})  # noqa: S307 (our own source)


def _self_field(node: ast.AST) -> str | None:
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "self":
        return node.attr
    return None


def _message_text(node: ast.AST, env: dict, text_src: str) -> str:
    """A rule's message as people read it: an f-string with the constants filled in, the value it got dropped."""
    if isinstance(node, ast.Constant):
        text = str(node.value)
    elif isinstance(node, ast.JoinedStr):
        parts = []
        for v in node.values:
            if isinstance(v, ast.Constant):
                parts.append(str(v.value))
            else:
                try:
                    parts.append(str(_const(v.value, env)))
                except Exception:  # refers to the message (self): not a constant
                    parts.append("{" + _source(text_src, v.value) + "}")
        text = "".join(parts)
    else:
        text = _source(text_src, node)
    return text.split(", got")[0].strip()


_OPS = {ast.Lt: ("exclusiveMaximum", "exclusiveMinimum"), ast.LtE: ("maximum", "minimum"),
        ast.Gt: ("exclusiveMinimum", "exclusiveMaximum"), ast.GtE: ("minimum", "maximum")}


def _bounds(cond: ast.AST, env: dict) -> dict[str, dict] | None:
    """Keywords per field for a condition JSON Schema can state, or None."""
    if isinstance(cond, ast.BoolOp) and isinstance(cond.op, ast.Or) and len(cond.values) == 2:
        a, b = cond.values      # "self.f is None or <bounds on f>": bounds apply to the number when there is one
        if (isinstance(a, ast.Compare) and isinstance(a.ops[0], ast.Is) and _self_field(a.left)
                and isinstance(a.comparators[0], ast.Constant) and a.comparators[0].value is None):
            return _bounds(b, env)
        return None
    if isinstance(cond, ast.BoolOp) and isinstance(cond.op, ast.And):
        out: dict[str, dict] = {}
        for v in cond.values:
            got = _bounds(v, env)
            if got is None:
                return None
            for f, kw in got.items():
                out.setdefault(f, {}).update(kw)
        return out
    if not isinstance(cond, ast.Compare):
        return None
    if len(cond.ops) == 1 and isinstance(cond.ops[0], ast.In) and _self_field(cond.left):
        try:
            return {_self_field(cond.left): {"enum": list(_const(cond.comparators[0], env))}}
        except Exception:
            return None
    if (len(cond.ops) == 1 and isinstance(cond.ops[0], ast.LtE) and isinstance(cond.left, ast.Call)
            and isinstance(cond.left.func, ast.Name) and cond.left.func.id == "len" and len(cond.left.args) == 1
            and _self_field(cond.left.args[0])):
        try:
            return {_self_field(cond.left.args[0]): {"maxItems": int(_const(cond.comparators[0], env))}}
        except Exception:
            return None
    terms = [cond.left, *cond.comparators]
    out = {}
    for (left, op, right) in zip(terms, cond.ops, terms[1:]):
        if type(op) not in _OPS:
            return None
        if _self_field(left) and not _self_field(right):
            f, node, kw = _self_field(left), right, _OPS[type(op)][0]
        elif _self_field(right) and not _self_field(left):
            f, node, kw = _self_field(right), left, _OPS[type(op)][1]
        else:
            return None
        try:
            value = _const(node, env)
        except Exception:
            return None
        if not isinstance(value, (int, float)):
            return None
        out.setdefault(f, {})[kw] = value
    return out


def message_rules(cls: type) -> list[dict]:
    """The message's own checks, from ``_rules`` (``_rule(cond, field, why)``) and ``__post_init__``
    (``raise ValueError(...)``): ``{"field", "check", "message", "keywords"}`` (keywords: what JSON
    Schema can say of it, by field; empty when it cannot)."""
    try:
        tree, _, src = _class_source(cls)
    except (OSError, TypeError):
        return []
    env = vars(inspect.getmodule(cls))
    out = []
    for fn in tree.body:
        if not (isinstance(fn, ast.FunctionDef) and fn.name in ("_rules", "__post_init__")):
            continue
        for node in ast.walk(fn):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "_rule"
                    and len(node.args) == 3):
                cond, where, why = node.args
                field = where.value if isinstance(where, ast.Constant) else _source(src, where)
                out.append({"field": field, "check": _source(src, cond), "message": _message_text(why, env, src),
                            "keywords": _bounds(cond, env) or {}})
            elif (isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call)
                  and isinstance(node.exc.func, ast.Name) and node.exc.func.id == "ValueError" and node.exc.args):
                text = _message_text(node.exc.args[0], env, src)
                field, _, why = text.partition(": ")
                if not why or " " in field:
                    field, why = "", text
                out.append({"field": field, "check": "", "message": why, "keywords": {}})
    return out


# --- types -> schemas ----------------------------------------------------------------------------
def _number(name: str) -> dict:
    s: dict[str, Any] = {"type": "number"}
    r = messages.field_range(name)
    if r is not None:
        lo, hi, lo_closed, hi_closed, _why = r
        if lo is not None:
            s["minimum" if lo_closed else "exclusiveMinimum"] = lo
        if hi is not None:
            s["maximum" if hi_closed else "exclusiveMaximum"] = hi
    return s


def _type_schema(name: str, tp: Any, defs: dict) -> dict:
    origin = typing.get_origin(tp)
    if origin is Annotated:
        base, *meta = typing.get_args(tp)
        cols = next((m.n for m in meta if isinstance(m, Columns)), None)
        if base is np.ndarray and cols is not None:
            row = _number(name) if cols == 0 else {"type": "array", "items": _number(name),
                                                   "minItems": cols, "maxItems": cols}
            return {"type": "array", "items": row, "maxItems": messages.MAX_LIST,
                    "x-shape": ["N"] if cols == 0 else ["N", cols]}
        return _type_schema(name, base, defs)
    if origin in (types.UnionType, typing.Union):
        (inner,) = [a for a in typing.get_args(tp) if a is not type(None)]
        return {"anyOf": [_type_schema(name, inner, defs), {"type": "null"}]}
    if tp is float:
        return _number(name)
    if tp is int:
        return {"type": "integer", "minimum": 0, "maximum": messages.MAX_INT - 1}
    if tp is str:
        if name in ID_FIELDS:
            return {"type": "string", "pattern": ID_JSON_PATTERN}
        return {"type": "string", "maxLength": messages.MAX_STR_LEN}
    if tp is bytes:
        return {"type": "string", "contentEncoding": "base64", "x-msgpack": "bin"}
    if origin is tuple:
        inner, _ell = typing.get_args(tp)
        return {"type": "array", "items": _type_schema(name, inner, defs), "maxItems": messages.MAX_LIST}
    if origin is dict:
        _k, v = typing.get_args(tp)
        return {"type": "object", "propertyNames": {"pattern": ID_JSON_PATTERN},
                "additionalProperties": _type_schema(name, v, defs), "maxProperties": messages.MAX_MAP_LEN}
    if isinstance(tp, type) and is_dataclass(tp):
        key = _def_name(tp)
        if key not in defs:
            defs[key] = {}            # a placeholder first: a type may refer to itself
            defs[key] = _object_schema(tp, defs)
        return {"$ref": f"#/$defs/{key}"}
    raise TypeError(f"{name}: no JSON Schema for {tp!r}")


def _keyword_target(s: dict | None, kw: dict) -> dict | None:
    """The (sub)schema a rule's keywords go into, or None when they do not fit its type."""
    if s is None:
        return None
    s = s["anyOf"][0] if "anyOf" in s else s
    t = s.get("type")
    ok = all((k == "enum" and t == "string") or (k == "maxItems" and t == "array")
             or (k.endswith(("imum",)) and t in ("number", "integer")) for k in kw)
    return s if ok else None


def _object_schema(cls: type, defs: dict, *, top: bool = False) -> dict:
    hints = typing.get_type_hints(cls, include_extras=True)
    comments = field_comments(cls)
    rules = message_rules(cls)
    props: dict[str, Any] = {}
    if top:   # as_dict's flat form carries the schema name beside the fields; the wire's data map does not
        props["schema"] = {"const": cls.SCHEMA, "description": "present in uvteam.messages.as_dict's form only"}
    required = []
    for f in fields(cls):
        s = _type_schema(f.name, hints[f.name], defs)
        props[f.name] = {"description": comments[f.name], **s} if f.name in comments else s
        if f.default is MISSING and f.default_factory is MISSING:
            required.append(f.name)
    loose = []
    for r in rules:
        targets = {f: _keyword_target(props.get(f), kw) for f, kw in r["keywords"].items()}
        if not r["keywords"] or not all(targets.values()):
            loose.append({"field": r["field"], "message": r["message"], **({"check": r["check"]} if r["check"] else {})})
            continue
        for f, kw in r["keywords"].items():
            targets[f].update(kw)
    out: dict[str, Any] = {"type": "object"}
    doc = inspect.getdoc(cls)
    if doc and doc != inspect.getdoc(object) and not doc.startswith(cls.__name__ + "("):
        out["description"] = " ".join(doc.split())
    out.update({"properties": props, "required": required, "additionalProperties": False})
    if loose:
        out["x-rules"] = loose
    return out


def json_schema(cls: type) -> dict:
    """A message type's JSON Schema (draft 2020-12), self-contained (its parts under ``$defs``)."""
    defs: dict[str, Any] = {}
    body = _object_schema(cls, defs, top=True)
    head = {"$schema": DIALECT, "$id": schema_id(cls), "title": cls.SCHEMA}
    extra = {"x-max-bytes": getattr(cls, "MAX_BYTES", messages.DEFAULT_MAX_BYTES),
             "x-zenoh-encoding": messages.encoding_of(cls),
             "x-topics": sorted(t for t, c in messages.BY_TOPIC.items() if c is cls)}
    return {**head, **body, **extra, **({"$defs": defs} if defs else {})}


def wire_schema(cls: type) -> dict:
    """The whole msgpack payload of one message type, ``{"schema": <const>, "data": <its map>}``, self-contained:
    what a recording (``uvteam record``) attaches to each channel of raw payloads."""
    s = json_schema(cls)
    defs = s.pop("$defs", {})
    head = {k: s.pop(k) for k in ("$schema", "$id", "title")}
    s["properties"].pop("schema", None)
    data = {k: v for k, v in s.items() if not k.startswith("x-")}
    out = {**head, "$id": head["$id"] + ":wire", "type": "object", "required": ["schema", "data"],
           "additionalProperties": False, "properties": {"schema": {"const": cls.SCHEMA}, "data": data},
           **{k: v for k, v in s.items() if k.startswith("x-")}}
    return {**out, "$defs": defs} if defs else out


def envelope_schema() -> dict:
    """The msgpack map on the wire, ``{"schema": "<name>/<version>", "data": {...}}``, for every message."""
    return {
        "$schema": DIALECT, "$id": "urn:uvteam:schema:envelope", "title": "envelope",
        "description": "Every uvteam payload: a msgpack map of the schema name and the message's fields.",
        "type": "object", "required": ["schema", "data"], "additionalProperties": False,
        "properties": {"schema": {"enum": [c.SCHEMA for c in TOP_LEVEL]}, "data": {"type": "object"}},
        "allOf": [{"if": {"properties": {"schema": {"const": c.SCHEMA}}},
                   "then": {"properties": {"data": {"$ref": schema_id(c)}}}} for c in TOP_LEVEL],
    }


def all_schemas() -> dict[str, dict]:
    """File name -> schema, for every top-level message and the envelope."""
    out = {file_name(c): json_schema(c) for c in TOP_LEVEL}
    out["envelope.schema.json"] = envelope_schema()
    return out


def dumps(schema: dict) -> str:
    return json.dumps(schema, indent=2, ensure_ascii=False) + "\n"


def write_schemas(directory: str | Path) -> list[Path]:
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    out = []
    for name, schema in all_schemas().items():
        p = d / name
        p.write_text(dumps(schema), encoding="utf-8")
        out.append(p)
    return out


def _jsonable(v: Any) -> Any:
    if isinstance(v, (bytes, bytearray)):
        return base64.b64encode(bytes(v)).decode("ascii")
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_jsonable(x) for x in v]
    return v


def to_json(msg: Any) -> dict:
    """A message as JSON data (:func:`uvteam.messages.as_dict`, bytes as base64 text): what the schemas validate."""
    return _jsonable(messages.as_dict(msg))


# --- the reference tables of docs/protocol.md ------------------------------------------------------
def _type_text(s: dict) -> str:
    if "$ref" in s:
        return f"[{s['$ref'].rsplit('/', 1)[-1]}](#{s['$ref'].rsplit('/', 1)[-1]})"
    if "anyOf" in s:
        return _type_text(s["anyOf"][0]) + " or null"
    t = s.get("type")
    if t == "array":
        if "x-shape" in s:
            return "array " + " x ".join(map(str, s["x-shape"])) + " of number"
        return "list of " + _type_text(s["items"])
    if t == "object" and "additionalProperties" in s:
        return "map id -> " + _type_text(s["additionalProperties"])
    if t == "string" and s.get("x-msgpack") == "bin":
        return "bytes (msgpack bin; base64 in JSON)"
    return str(t) if t else "const"


def _limits_text(s: dict) -> str:
    s = s["anyOf"][0] if "anyOf" in s else s
    if s.get("type") == "array" and "x-shape" in s:
        s = s["items"] if s["x-shape"] == ["N"] else s["items"]["items"]
    parts = []
    lo = ("[", s["minimum"]) if "minimum" in s else ("(", s["exclusiveMinimum"]) if "exclusiveMinimum" in s else None
    hi = (s["maximum"], "]") if "maximum" in s else (s["exclusiveMaximum"], ")") if "exclusiveMaximum" in s else None
    if lo or hi:
        parts.append(f"{lo[0] if lo else '('}{lo[1] if lo else '-inf'}, {hi[0] if hi else 'inf'}{hi[1] if hi else ')'}"
                     .replace("9007199254740991", "2^53-1").replace("10000000000.0", "1e10"))
    if "enum" in s:
        parts.append("one of " + ", ".join(f"`{x}`" for x in s["enum"]))
    if "pattern" in s:
        parts.append("an id: 1-32 of A-Z a-z 0-9 _ -")
    if "maxItems" in s and s.get("type") == "array":
        parts.append(f"<= {s['maxItems']} items")
    return "; ".join(parts)


def field_rows(schema: dict) -> list[tuple[str, str, str, str, str]]:
    """(field, type, required, limits, description) per property of an object schema."""
    rows = []
    for name, s in schema["properties"].items():
        if name == "schema":
            continue
        rows.append((name, _type_text(s), "yes" if name in schema["required"] else "no", _limits_text(s),
                     s.get("description", "")))
    return rows


def _table(schema: dict) -> list[str]:
    out = ["| field | type | required | limits | meaning |", "|---|---|---|---|---|"]
    for row in field_rows(schema):
        out.append("| " + " | ".join(c.replace("|", "\\|") for c in row) + " |")
    if schema.get("x-rules"):
        out.append("")
    for r in schema.get("x-rules", []):
        out.append(f"- {('`' + r['field'] + '`: ') if r['field'] else ''}{r['message']}")
    return out


def markdown_reference() -> str:
    """The generated part of docs/protocol.md: one section per message and per part."""
    lines: list[str] = []
    parts: dict[str, dict] = {}
    for cls in TOP_LEVEL:
        s = json_schema(cls)
        topics = ", ".join(f"`{t}`" for t in s["x-topics"])
        lines += [f"### {cls.SCHEMA}", "", s.get("description", ""), "",
                  f"Topics {topics}; zenoh encoding `{s['x-zenoh-encoding']}`; at most {s['x-max-bytes']} bytes; "
                  f"schema [`schemas/{file_name(cls)}`](schemas/{file_name(cls)}).", ""]
        lines += _table(s) + [""]
        parts.update(s.get("$defs", {}))
    for name, s in parts.items():
        lines += [f"### {name}", ""]
        if s.get("description"):
            lines += [s["description"], ""]
        lines += _table(s) + [""]
    return "\n".join(lines).rstrip() + "\n"
