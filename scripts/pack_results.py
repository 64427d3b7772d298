#!/usr/bin/python3
"""Packs result directories before they are committed, so that results/ stays under its size
limit (scripts/check_repo_size.sh, results/README.md "What is committed, and how").

Usage: /usr/bin/python3 scripts/pack_results.py [--png] [--keep-runs] DIR...

Under each DIR, recursively:
  - every `cases.jsonl` (insid-diagnose-campaign's raw records) becomes `cases.jsonl.xz`;
  - every campaign run file `runs/<scenario>/<algorithm>/seed_<k>.json` becomes
    `seed_<k>.json.xz` (unless --keep-runs);
  - every summary (`summary.json`, `*-summary.json`) that holds convergence curves
    (`curve_evaluations`, `curve_iterations`: one value per iteration or evaluation step) is
    split: `NAME.full.json.xz` keeps the whole file byte for byte, and `NAME.json` is rewritten
    without the curves (every other value as it was, insid's layout: one-space indent), so that
    the numbers the READMEs quote stay readable in plain JSON;
  - with --png, every `.png` is quantized in place by Debian's `pngquant` (quality 85-98, the
    figures look the same; skipped with a note where pngquant is absent).
The readers (scripts/campaign_report.py, accuracy_table.py, compare_summaries.py,
diagnose_campaign_report.py, diagnose_rejudge.py, perf_phases.sh) read the packed forms: a
summary's `.full.json.xz` where it exists and the plain summary is that file less its curves (a
summary written again since makes the companion stale: it is then ignored, and packing again
replaces it), a `.xz` where the plain file is absent. xz is lossless: `xz -dk FILE.xz` gives
the file back as the program wrote it.
"""
import argparse
import json
import lzma
import os
import shutil
import subprocess
import sys

CURVES = ("curve_evaluations", "curve_iterations")


def xz_bytes(data):
    return lzma.compress(data, format=lzma.FORMAT_XZ, preset=9 | lzma.PRESET_EXTREME)


def compress(path):
    """PATH -> PATH.xz (the plain file removed)."""
    with open(path, "rb") as f:
        data = f.read()
    with open(path + ".xz", "wb") as f:
        f.write(xz_bytes(data))
    os.remove(path)
    return len(data), os.path.getsize(path + ".xz")


def has_curves(value):
    if isinstance(value, dict):
        return any(k in CURVES for k in value) or any(has_curves(v) for v in value.values())
    if isinstance(value, list):
        return any(has_curves(v) for v in value)
    return False


def without_curves(value):
    if isinstance(value, dict):
        return {k: without_curves(v) for k, v in value.items() if k not in CURVES}
    if isinstance(value, list):
        return [without_curves(v) for v in value]
    return value


def load_packed(path, warn):
    """The JSON at PATH as it was written, whatever form it is committed in: PATH.xz when only
    that exists, and for a summary NAME.json the whole NAME.full.json.xz beside it when NAME.json
    is that file less its curves (otherwise NAME.json was written again since: the companion is
    stale, `warn` says so, and NAME.json is read). Raises OSError / ValueError as json.load."""
    if not os.path.exists(path) and os.path.exists(path + ".xz"):
        path += ".xz"
    with (lzma.open(path, "rt") if path.endswith(".xz") else open(path)) as f:
        value = json.load(f)
    full_path = path[:-len(".json")] + ".full.json.xz" if path.endswith(".json") else ""
    if full_path and os.path.exists(full_path):
        try:
            with lzma.open(full_path, "rt") as f:
                full = json.load(f)
        except (OSError, ValueError, lzma.LZMAError) as e:
            warn(f"skipping {full_path}: {e}")
            return value
        if without_curves(full) == value:
            return full
        warn(f"{full_path} is not {path} with its curves (stale?): reading {path}")
    return value


def split_summary(path):
    """NAME.json -> NAME.full.json.xz (whole) + NAME.json (no curves); None if no curves."""
    with open(path, "rb") as f:
        data = f.read()
    summary = json.loads(data)
    if not has_curves(summary):
        return None
    full = path[:-len(".json")] + ".full.json.xz"
    with open(full, "wb") as f:
        f.write(xz_bytes(data))
    lean = json.dumps(without_curves(summary), indent=1, ensure_ascii=False) + "\n"
    with open(path, "w") as f:
        f.write(lean)
    return len(data), len(lean.encode()) + os.path.getsize(full)


def quantize(path):
    before = os.path.getsize(path)
    tmp = path + ".pq.png"
    r = subprocess.run(["pngquant", "--quality=85-98", "--speed", "1", "--strip", "--force",
                        "--output", tmp, path], capture_output=True)
    if r.returncode == 0 and os.path.getsize(tmp) < before:
        os.replace(tmp, path)
    elif os.path.exists(tmp):
        os.remove(tmp)
    return before, os.path.getsize(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--png", action="store_true", help="quantize the figures with pngquant")
    ap.add_argument("--keep-runs", action="store_true", help="leave runs/**/seed_*.json plain")
    args = ap.parse_args()
    png = args.png and shutil.which("pngquant")
    if args.png and not png:
        print("pack_results: pngquant is absent (apt-get install pngquant): figures left as they are",
              file=sys.stderr)
    totals = {}
    for top in args.dirs:
        for root, _, files in os.walk(top):
            for name in sorted(files):
                path = os.path.join(root, name)
                kind, sizes = None, None
                if name == "cases.jsonl":
                    kind, sizes = "cases", compress(path)
                elif (not args.keep_runs and name.startswith("seed_") and name.endswith(".json")
                      and os.sep + "runs" + os.sep in path):
                    kind, sizes = "runs", compress(path)
                elif name == "summary.json" or name.endswith("-summary.json"):
                    kind, sizes = "summaries", split_summary(path)
                elif png and name.endswith(".png"):
                    kind, sizes = "figures", quantize(path)
                if sizes:
                    t = totals.setdefault(kind, [0, 0, 0])
                    t[0] += 1
                    t[1] += sizes[0]
                    t[2] += sizes[1]
    for kind, (n, before, after) in sorted(totals.items()):
        print(f"pack_results: {kind}: {n} files, {before} -> {after} bytes")


if __name__ == "__main__":
    main()
