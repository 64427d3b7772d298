#!/usr/bin/python3
"""A diagnose campaign's cases.jsonl stored as its differences from another one
(so that results/ stays small).

results/diagnose/mems-forward-only holds the first 508 cases of results/diagnose/mems as the
forward-only binary wrote them; ../mems carries the same rows with a few fields changed or added
(`withdrawn`, `carried_from_forward_only_run`, some `found`, `wall_s`). Committing both whole
doubled 1.9 MB of compressed records; the delta keeps only what differs, top-level field by
field, as the original text (so that the file comes back byte for byte; SHA-256 checked).

Usage:
  scripts/cases_delta.py make BASE FULL > DELTA          (DELTA: JSON lines; xz it to commit)
  scripts/cases_delta.py apply BASE DELTA [--sha256 HEX] > FULL
BASE, FULL and DELTA may be plain or .xz. `apply` with --sha256 fails (exit 1) unless the
rebuilt file has that SHA-256. Example (the committed forward-only cases):
  /usr/bin/python3 scripts/cases_delta.py apply results/diagnose/mems/cases.jsonl.xz \\
      results/diagnose/mems-forward-only/cases.delta.jsonl.xz \\
      --sha256 "$(cat results/diagnose/mems-forward-only/cases.jsonl.sha256)" \\
      > results/diagnose/mems-forward-only/cases.jsonl
"""
import argparse
import hashlib
import json
import lzma
import sys

DECODER = json.JSONDecoder()


def read_lines(path):
    with (lzma.open(path, "rt", encoding="utf-8", newline="") if path.endswith(".xz")
          else open(path, encoding="utf-8", newline="")) as f:
        return f.read().splitlines(keepends=True)


def fields(line):
    """The top-level members of one JSON object line: [(raw key, raw value)], the line's text
    between them being ',' and ':' (insid writes compact JSON; anything else is refused)."""
    body = line.rstrip("\n")
    if not body.startswith("{") or not body.endswith("}"):
        raise ValueError("not a one-line JSON object")
    out, pos = [], 1
    if body == "{}":
        return out
    while True:
        _, end = DECODER.raw_decode(body, pos)
        key = body[pos:end]
        if body[end] != ":":
            raise ValueError("not compact JSON")
        _, vend = DECODER.raw_decode(body, end + 1)
        out.append((key, body[end + 1:vend]))
        if body[vend] == "}":
            if vend != len(body) - 1:
                raise ValueError("text after the object")
            return out
        if body[vend] != ",":
            raise ValueError("not compact JSON")
        pos = vend + 1


def join(members, newline):
    return "{" + ",".join(k + ":" + v for k, v in members) + "}" + newline


def case_key(members):
    return dict(members).get('"key"')


def make(base_lines, full_lines):
    base = {}
    for line in base_lines:
        m = fields(line)
        base.setdefault(case_key(m), dict(m))
    for line in full_lines:
        m = fields(line)
        newline = line[len(line.rstrip("\n")):]
        b = base.get(case_key(m))
        if b is None:
            yield {"line": line}
            continue
        yield {"key": case_key(m), "order": [k for k, _ in m], "newline": newline,
               "set": {k: v for k, v in m if b.get(k) != v}}


def apply(base_lines, delta_lines):
    base = {}
    for line in base_lines:
        m = fields(line)
        base.setdefault(case_key(m), dict(m))
    for line in delta_lines:
        d = json.loads(line)
        if "line" in d:
            yield d["line"]
            continue
        b = base[d["key"]]
        yield join([(k, d["set"][k] if k in d["set"] else b[k]) for k in d["order"]], d["newline"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("action", choices=("make", "apply"))
    ap.add_argument("base")
    ap.add_argument("other", help="FULL (make) or DELTA (apply)")
    ap.add_argument("--sha256", help="apply: the SHA-256 the rebuilt file must have")
    args = ap.parse_args()
    base_lines = read_lines(args.base)
    other = read_lines(args.other)
    out = sys.stdout
    if args.action == "make":
        delta = [json.dumps(d, separators=(",", ":"), ensure_ascii=False) + "\n"
                 for d in make(base_lines, other)]
        rebuilt = "".join(apply(base_lines, delta))
        if rebuilt != "".join(other):
            sys.exit("cases_delta: the delta does not give the file back (not compact JSON?)")
        out.write("".join(delta))
        return
    text = "".join(apply(base_lines, other))
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
    if args.sha256 and digest != args.sha256.strip():
        sys.exit(f"cases_delta: the rebuilt file's SHA-256 is {digest}, not {args.sha256.strip()}")
    out.write(text)
    print(f"cases_delta: {len(other)} cases rebuilt, SHA-256 {digest}", file=sys.stderr)


if __name__ == "__main__":
    main()
