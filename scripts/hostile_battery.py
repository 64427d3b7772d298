#!/usr/bin/python3
"""The hostile-input battery, as a script: run insid on inputs a careless or hostile user
gives it and classify every outcome.

    /usr/bin/python3 scripts/hostile_battery.py [--insid build/cli/insid] [--shared ../shared]
                                                [--random-flips 400] [--seed 1] [--json FILE]

Each case runs one insid command (in a scratch directory, at low priority, under a 4 GiB address
space limit) and is classified:
  clear     exit 1 or 2 as the case expects, the message names what it must (the file, line,
            byte, option or limit) and holds no raw library text ("json.exception", "bad_alloc"
            alone);
  accepted  exit 0 where the input is valid or its damage is accounted for (e.g. a ULog with a
            corrupted stamp: the dropped rows counted in provenance.json and printed; a damaged
            log that reads fewer IMU rows than the intact one says why: a damaged place
            skipped, a truncation or a timestamp jump);
  weak      an error, but with the wrong exit code or a message that misses what it must name;
  silent    exit 0 where an error (or a note) was due;
  crash     killed by a signal, or an exit code outside 0-2;
  memory    a child's peak RSS above the case's bound;
  lost      a file the user owned changed or disappeared, or something was written outside --out.
The script prints one line per case and the counts, and exits 1 unless every case is clear or
accepted (so ctest can run it: `ctest -R hostile_battery`). Cases that need ../shared/data are
skipped, and counted as such, where it is absent. Random damage (item 4) flips 1 or 5 bytes at
--random-flips places, half in the shared ULog, half in the shared DataFlash log (200 each by
default). Takes about 80 s on 2 cores.
"""

import argparse
import hashlib
import json
import os
import random
import resource
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

GIB = 1 << 30


class Battery:
    def __init__(self, insid, shared, work):
        self.insid = insid
        self.shared = shared
        self.work = work
        self.results = []  # (item, name, verdict, detail)

    # --- running -------------------------------------------------------------------------------
    def run(self, args, stdin=None, timeout=120):
        """Runs insid with `args`; returns (exit code or -signal, output, its peak RSS in MB)."""

        def limit():
            os.nice(10)
            resource.setrlimit(resource.RLIMIT_AS, (4 * GIB, 4 * GIB))

        with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as inp:
            inp.write(stdin or b"")
            inp.seek(0)
            proc = subprocess.Popen([self.insid] + args, cwd=self.work, stdin=inp, stdout=out,
                                    stderr=subprocess.STDOUT, preexec_fn=limit)
            timer = threading.Timer(timeout, proc.kill)
            timer.start()
            _, status, usage = os.wait4(proc.pid, 0)  # this child's own rusage
            timer.cancel()
            proc.returncode = os.waitstatus_to_exitcode(status)
            out.seek(0)
            text = out.read().decode("utf-8", "replace")
        return proc.returncode, text, usage.ru_maxrss / 1024.0

    def record(self, item, name, verdict, detail=""):
        self.results.append((item, name, verdict, detail))
        print(f"[{verdict:8}] item {item:>2} {name}" + (f": {detail}" if detail else ""),
              flush=True)

    def expect_error(self, item, name, args, codes=(1,), must=(), protect=(), stdin=None,
                     rss_mb=None, outside=None):
        """A case whose right answer is an error with exit code in `codes`, a message holding
        every string in `must`, every file in `protect` unchanged, and nothing new in the
        directory `outside`."""
        before = {p: digest(p) for p in protect}
        outside_before = listing(outside) if outside else None
        code, out, rss = self.run(args, stdin=stdin)
        lost = [str(p) for p in protect if digest(p) != before[p]]
        if outside is not None and listing(outside) != outside_before:
            lost.append(f"wrote into {outside}")
        first = out.strip().splitlines()[-1] if out.strip() else "(no output)"
        if code < 0 or code > 2:
            self.record(item, name, "crash", f"exit {code}: {first}")
        elif lost:
            self.record(item, name, "lost", ", ".join(lost))
        elif rss_mb is not None and rss > rss_mb:
            self.record(item, name, "memory", f"{rss:.0f} MB > {rss_mb} MB")
        elif code == 0:
            self.record(item, name, "silent", "exit 0")
        elif code not in codes or not all(m in out for m in must) or raw_library_text(out):
            missing = [m for m in must if m not in out]
            self.record(item, name, "weak",
                        f"exit {code} (expected {codes}), missing {missing}: {first[:160]}")
        else:
            self.record(item, name, "clear", first[:160])

    def expect_accept(self, item, name, args, check=None, protect=()):
        """A case whose right answer is exit 0; `check(output)` returns "" when the output
        accounts for what it must, else what it misses."""
        before = {p: digest(p) for p in protect}
        code, out, _ = self.run(args)
        lost = [str(p) for p in protect if digest(p) != before[p]]
        first = out.strip().splitlines()[-1] if out.strip() else "(no output)"
        if code < 0 or code > 2:
            self.record(item, name, "crash", f"exit {code}: {first}")
        elif lost:
            self.record(item, name, "lost", ", ".join(lost))
        elif code != 0:
            self.record(item, name, "weak", f"exit {code}: {first[:160]}")
        else:
            why = check(out) if check else ""
            self.record(item, name, "silent" if why else "accepted", why)

    def skip(self, item, name, why):
        self.results.append((item, name, "skipped", why))
        print(f"[skipped ] item {item:>2} {name}: {why}", flush=True)


def digest(path):
    path = Path(path)
    if path.is_symlink():
        return "link:" + os.readlink(path)
    if path.is_dir():
        return "dir:" + ",".join(sorted(p.name for p in path.iterdir()))
    if not path.exists():
        return None
    return hashlib.sha256(path.read_bytes()).hexdigest()


def listing(directory):
    return sorted(str(p.relative_to(directory)) for p in Path(directory).rglob("*"))


def raw_library_text(output):
    return "[json.exception" in output or output.strip().endswith("std::bad_alloc")


def write(path, data):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


# --- the cases --------------------------------------------------------------------------------
def ownership_cases(b, sim, walk):
    w = b.work
    # Item 1: an import into the folder of its own raw log, and look-alike directories.
    if walk:
        d = w / "own"
        d.mkdir()
        raw = Path(shutil.copy(walk / "imu_1730_sf.csv", d / "imu.csv"))
        b.expect_error(1, "import csv into the folder of its raw imu.csv",
                       ["import", "csv", "--imu", str(raw), "--columns",
                        "t,ax,ay,az,gx,gy,gz,-,-,-,-", "--units", "s,g-local,rad/s", "--gnss",
                        str(walk / "gnss_1730_sf.pos"), "--align-s", "9", "--out", str(d)],
                       codes=(1, 2), must=["imu.csv"], protect=[raw])
        b.expect_error(1, "... with --force (inputs are never replaced)",
                       ["import", "csv", "--imu", str(raw), "--columns",
                        "t,ax,ay,az,gx,gy,gz,-,-,-,-", "--units", "s,g-local,rad/s", "--gnss",
                        str(walk / "gnss_1730_sf.pos"), "--align-s", "9", "--force", "--out",
                        str(d)], codes=(1, 2), must=["imu.csv"], protect=[raw])
    else:
        b.skip(1, "import csv into the folder of its raw imu.csv", "no shared walk")
    look = w / "lookalike"
    files = [write(look / n, f"user's own {n}\n") for n in
             ("imu.csv", "gnss.csv", "truth.csv", "meta.json")]
    b.expect_error(1, "simulate into a directory of look-alike names (no insid mark)",
                   ["simulate", "--preset", "straight", "--flight-s", "20", "--out", str(look)],
                   must=[str(look)], protect=files)
    kf = w / "kf"
    b.run(["export", "--to", "kf-gins", "--data", str(sim), "--out", str(kf)])
    kf_imu = kf / "imu.txt"
    kf_args = ["import", "kf-gins", "--imu", str(kf_imu), "--gnss", str(kf / "gnss.txt"),
               "--out", str(kf)]
    b.expect_error(1, "import kf-gins into the folder of its own imu.txt", kf_args,
                   must=[str(kf)], protect=[kf_imu, kf / "gnss.txt"])
    b.expect_accept(1, "... with --force: the dataset added beside imu.txt, gnss.txt",
                    kf_args + ["--force"], protect=[kf_imu, kf / "gnss.txt"],
                    check=lambda out: "" if (kf / "meta.json").exists() else "no meta.json")

    # Item 5: outputs over the command's own inputs, and over a user's file.
    data_files = [sim / "imu.csv", sim / "gnss.csv", sim / "meta.json", sim / "truth.csv"]
    for name, args in [
        ("navigate --out <data>/imu.csv", ["navigate", "--data", str(sim), "--out",
                                           str(sim / "imu.csv")]),
        ("navigate --summary <data>/meta.json", ["navigate", "--data", str(sim), "--out",
                                                 str(w / "nav.csv"), "--summary",
                                                 str(sim / "meta.json")]),
        ("navigate --out <data>/truth.csv --force", ["navigate", "--data", str(sim), "--out",
                                                     str(sim / "truth.csv"), "--force"]),
        ("identify --out <data>/meta.json", ["identify", "--data", str(sim), "--algo", "lm",
                                             "--no-reference-optimum", "--out",
                                             str(sim / "meta.json")]),
        ("diagnose --out <data>/truth.csv", ["diagnose", "--data", str(sim), "--out",
                                             str(sim / "truth.csv")]),
    ]:
        b.expect_error(5, name, args, must=["which this command reads"], protect=data_files)
    user = write(w / "notes.json", '{"mine": true}\n')
    b.expect_error(5, "navigate --summary over a user's existing file",
                   ["navigate", "--data", str(sim), "--out", str(w / "nav2.csv"), "--summary",
                    str(user)], codes=(1, 2), must=["notes.json"], protect=[user])


def round_three_ownership_cases(b, sim):
    """Data-loss cases: names that look like insid's temporaries, a folder where a
    dataset writes a file, --force over the command's own input, two outputs at one path, and
    what a killed simulate leaves."""
    w = b.work
    # A folder of the user's with look-alike temporaries, as bench --force's --out (twice: the
    # second run removes stale temporaries).
    photos = w / "photos"
    img = write(photos / "photos.tmp-laptop-12-3" / "img1.jpg", "jpeg bytes\n")
    lst = write(photos / "list.tmp-h-1-2", "the user's list\n")
    config = write(w / "camp45.json", json.dumps(campaign_config("straight")))
    bench = ["bench", "--config", str(config), "--threads", "1", "--force", "--out", str(photos)]
    for attempt in ("first", "second"):
        b.expect_accept("45", f"bench --force into a folder of look-alike temporaries ({attempt})",
                        bench, protect=[img, lst])
    # ds/provenance.json/notes.txt: a user's folder named like a dataset file.
    ds = w / "ds45"
    b.run(["simulate", "--preset", "straight", "--flight-s", "10", "--out", str(ds)])
    notes = write(ds / "provenance.json" / "notes.txt", "the user's notes\n")
    b.expect_error("45", "simulate over a dataset holding a user's folder provenance.json/",
                   ["simulate", "--preset", "straight", "--flight-s", "10", "--out", str(ds)],
                   must=["provenance.json"], protect=[notes])
    # --force never overwrites the command's own input.
    code, out, _ = b.run(["simulate", "--preset", "straight", "--flight-s", "10",
                          "--print-config"])
    cfg = write(w / "cfg45" / "meta.json", out[out.index("{"):])
    b.expect_error("45", "simulate --config cfg/meta.json --force --out cfg",
                   ["simulate", "--config", str(cfg), "--force", "--out", str(cfg.parent)],
                   must=["which this command reads"], protect=[cfg])
    bc = write(w / "bc45" / "summary.json", json.dumps(campaign_config("straight")))
    b.expect_error("45", "bench --config bc/summary.json --force --out bc",
                   ["bench", "--config", str(bc), "--force", "--threads", "1", "--out",
                    str(bc.parent)], must=["which this command reads"], protect=[bc])
    # Two outputs of one command at one path.
    b.expect_error("45", "diagnose --out X --report X",
                   ["diagnose", "--data", str(sim), "--out", str(w / "x45.json"), "--report",
                    str(w / "x45.json")], codes=(2,), must=["are the same file"])
    # Absurd sizes refused before the work: 2 GiB of zeros as an IMU CSV (under the size
    # limit), a campaign of 30 x 30 x 100000 runs.
    zeros = w / "zeros45.csv"
    with open(zeros, "wb") as f:
        f.truncate(2 << 30)
    gnss45 = write(w / "gnss45.txt", "".join(f"{345600 + k}.0 40.0 116.0 50.0 0.01 0.01 0.02\n"
                                             for k in range(3)))
    b.expect_error("45", "2 GiB of zeros as the IMU CSV",
                   ["import", "kf-gins", "--imu", str(zeros), "--gnss", str(gnss45), "--out",
                    str(w / "zeros45")], must=["not a text file: byte 0 is a NUL byte"],
                   rss_mb=512)
    huge = campaign_config("s0")
    huge["scenarios"] = [{"name": f"s{k}", "preset": "straight", "flight_s": 20} for k in range(30)]
    huge["algorithms"] = [{"label": f"P{k}", "name": "pso"} for k in range(30)]
    huge["seeds"] = 100000
    huge_cfg = write(w / "huge45.json", json.dumps(huge))
    b.expect_error("45", "a campaign of 30 x 30 x 100000 runs",
                   ["bench", "--config", str(huge_cfg), "--out", str(w / "huge45")],
                   must=["90000000 runs", "limit"], rss_mb=512)
    # What a simulate killed mid-write leaves (its marked temporary directory, a dead pid of
    # this host): the next simulate into the same --out removes it.
    dead = subprocess.Popen(["true"])
    dead.wait()
    target = w / "killed45"
    leftover = target.parent / f"killed45.tmp-{socket.gethostname()}-{dead.pid}-0"
    # Its files as insid leaves them: one written (insid's mark, the SHA-256 of its bytes), one
    # being written (a marked temporary).
    done = write(leftover / "imu.csv", "t_s\n")
    half = write(leftover / f"gnss.csv.tmp-{socket.gethostname()}-{dead.pid}-1", "t_s,la")
    try:
        mark = f"{socket.gethostname()}-{dead.pid}".encode()
        os.setxattr(done, "user.insid.sha256", hashlib.sha256(b"t_s\n").hexdigest().encode())
        os.setxattr(half, "user.insid.temporary", mark)
        os.setxattr(leftover, "user.insid.temporary", mark)
    except OSError:
        b.skip("45", "a killed simulate's temporary removed by the rerun",
               "no user extended attributes here")
        return
    b.expect_accept("45", "a killed simulate's temporary removed by the rerun",
                    ["simulate", "--preset", "straight", "--flight-s", "10", "--out",
                     str(target)],
                    check=lambda out: "" if not leftover.exists() else f"{leftover} left")


def campaign_config(scenario_name):
    """A campaign of one short straight flight, PSO with 40 evaluations, one seed."""
    return {"name": "battery", "seeds": 1, "max_iterations": 0, "max_evaluations": 40,
            "scenarios": [{"name": scenario_name, "preset": "straight", "flight_s": 20}],
            "algorithms": [{"label": "PSO", "name": "pso"}]}


def campaign_cases(b):
    w = b.work
    config = write(w / "camp.json", json.dumps(campaign_config("straight")))
    bench = ["bench", "--config", str(config), "--threads", "1", "--out"]
    # Item 2: links planted where a campaign writes.
    outside = w / "outside"
    outside.mkdir()
    victim = write(outside / "victim.txt", "the user's file\n")
    for link_name in (".insid-lock", "runs", "optimum", "summary.json"):
        d = w / f"link-{link_name.strip('.')}"
        d.mkdir()
        os.symlink(victim if "." in link_name else outside, d / link_name)
        b.expect_error(2, f"campaign with {link_name} a link outside --out", bench + [str(d)],
                       codes=(1, 2), must=[link_name], protect=[victim], outside=outside)
    # Item 6: a directory holding only the user's summary.json; --force-new and a user's file.
    d = w / "user-summary"
    summary = write(d / "summary.json", '{"mine": true}\n')
    b.expect_error(6, "campaign into a directory holding only a user's summary.json",
                   bench + [str(d)], codes=(1, 2), must=["summary.json"], protect=[summary])
    d = w / "camp-ok"
    code, out, _ = b.run(bench + [str(d)])
    if code != 0:
        b.record(6, "a campaign runs (set-up of the --force-new case)", "weak", out[-200:])
        return
    notes = write(d / "runs" / "notes.txt", "the user's notes\n")
    other = write(w / "camp2.json", json.dumps(campaign_config("straight2")))
    b.expect_error(6, "--force-new (another campaign) with a user's runs/notes.txt",
                   ["bench", "--config", str(other), "--threads", "1", "--out", str(d),
                    "--force-new"], must=["notes.txt"], protect=[notes])
    # Item 8: a scenario named like insid's temporary files.
    tmp_named = write(w / "tmpname.json", json.dumps(campaign_config("x.tmp-host-1-2")))
    b.expect_error(8, "scenario label x.tmp-host-1-2", ["bench", "--config", str(tmp_named),
                                                        "--out", str(w / "tmpname")],
                   codes=(1, 2), must=["x.tmp-host-1-2"])


def json_cases(b, sim):
    w = b.work
    # Item 7: nesting depth and size, as a config and as meta.json.
    deep = write(w / "deep.json", "[" * 100000 + "]" * 100000)
    b.expect_error(7, "bench --config of 100 000 nested [", ["bench", "--config", str(deep),
                                                            "--out", str(w / "deepc")],
                   codes=(1, 2), must=["deep.json", "nesting depth"], rss_mb=256)
    ds = w / "deepmeta"
    shutil.copytree(sim, ds)
    (ds / "meta.json").write_text("[" * 100000 + "]" * 100000)
    b.expect_error(7, "meta.json of 100 000 nested [", ["navigate", "--data", str(ds), "--out",
                                                       str(w / "deepnav.csv")],
                   must=["meta.json", "nesting depth"], rss_mb=256)
    flat = write(w / "flat.json", "[" + "0," * (40 << 20) + "0]")
    b.expect_error(7, "an 80 MB config (over the 64 MiB limit)", ["bench", "--config", str(flat),
                                                                 "--out", str(w / "flatc")],
                   codes=(1, 2), must=["flat.json"], rss_mb=256)
    # Item 12: bad JSON without nlohmann's tag; a duplicate key named.
    bad = write(w / "bad.json", '{"name": "battery", "seeds": 1,}')
    b.expect_error(12, "config with a trailing comma", ["bench", "--config", str(bad), "--out",
                                                        str(w / "badc")], codes=(1, 2),
                   must=["bad.json", "line 1"])
    dup = write(w / "dup.json", '{"name": "battery", "seeds": 1, "seeds": 2}')
    b.expect_error(12, "config with a key twice", ["bench", "--config", str(dup), "--out",
                                                   str(w / "dupc")], codes=(1, 2),
                   must=["dup.json", "seeds"])


def external_cases(b, sim):
    w = b.work
    est = ["--estimate", "accel_bias_x", "--estimate", "accel_bias_y"]

    def client(name, body):
        return write(w / f"{name}.py", "import sys, json\n" + body)

    clients = {
        "reply 100 000 nested [": (client("deep", (
            "for line in sys.stdin:\n"
            "    if json.loads(line)['type'] == 'ask':\n"
            "        print('{\"points\": ' + '[' * 100000 + ']' * 100000 + '}', flush=True)\n")),
            ["nesting depth"]),
        "two replies per ask": (client("twice", (
            "for line in sys.stdin:\n"
            "    m = json.loads(line)\n"
            "    if m['type'] == 'problem': n = m['dimension']\n"
            "    if m['type'] == 'ask':\n"
            "        print(json.dumps({'points': [[0.0] * n]}), flush=True)\n"
            "        print(json.dumps({'points': [[0.0] * n]}), flush=True)\n")),
            ["answers no ask"]),
        "a point outside the box": (client("outside", (
            "for line in sys.stdin:\n"
            "    m = json.loads(line)\n"
            "    if m['type'] == 'problem': n = m['dimension']\n"
            "    if m['type'] == 'ask':\n"
            "        print(json.dumps({'points': [[1e9] * n]}), flush=True)\n")),
            ["outside"]),
        "exits before replying": (client("quits", "sys.exit(3)\n"), ["exit"]),
        "a NaN in a point": (client("nan", (
            "for line in sys.stdin:\n"
            "    m = json.loads(line)\n"
            "    if m['type'] == 'problem': n = m['dimension']\n"
            "    if m['type'] == 'ask':\n"
            "        print('{\"points\": [[' + ','.join(['NaN'] * n) + ']]}', flush=True)\n")),
            ["line"]),
    }
    for name, (path, must) in clients.items():
        b.expect_error(3 if "nested" in name else 13, f"external client: {name}",
                       ["identify", "--data", str(sim), "--algo",
                        f"external:/usr/bin/python3 {path}", "--no-reference-optimum",
                        "--evaluations", "20", "--out", str(w / f"ext-{path.stem}.json")] + est,
                       must=must, rss_mb=512)


def reader_cases(b, sim, walk, shared):
    w = b.work
    # Item 9: huge inputs refused before being read.
    huge = w / "huge.ulg"
    with open(huge, "wb") as f:
        f.truncate(3 * GIB)
    b.expect_error(9, "a 3 GiB file of zeros as a ULog", ["import", "ulog", str(huge), "--out",
                                                         str(w / "hugeu")],
                   must=["huge.ulg"], rss_mb=256)
    big = w / "big.csv"
    with open(big, "wb") as f:
        f.truncate(5 * GIB)
    b.expect_error(9, "a 5 GiB IMU CSV (over --max-input-mb)",
                   ["import", "csv", "--imu", str(big), "--columns", "t,ax,ay,az,gx,gy,gz",
                    "--units", "s,g,rad/s", "--gnss", str(big), "--out", str(w / "bigc")],
                   must=["big.csv", "--max-input-mb"], rss_mb=256)
    big.unlink()
    huge.unlink()
    if not walk:
        b.skip(10, "walk cases", "no shared walk")
        return
    imu, pos = walk / "imu_1730_sf.csv", walk / "gnss_1730_sf.pos"
    walk_args = ["--columns", "t,ax,ay,az,gx,gy,gz,-,-,-,-", "--units", "s,g-local,rad/s",
                 "--mounting-rpy-deg", "180,0,-90"]
    pos_lines = pos.read_text().splitlines(keepends=True)
    header = sum(1 for line in pos_lines if line.startswith("%"))

    def pos_with(line_no, edit):
        lines = list(pos_lines)
        lines[line_no - 1] = edit(lines[line_no - 1])
        return write(w / f"rover-{line_no}-{len(b.results)}.pos", "".join(lines))

    def import_walk(name, gnss, extra=(), item=10, must=(), codes=(1,), imu_file=imu):
        b.expect_error(item, name, ["import", "csv", "--imu", str(imu_file)] + walk_args +
                       ["--gnss", str(gnss)] + list(extra) + ["--out",
                                                             str(w / f"walk{len(b.results)}")],
                       codes=codes, must=must)

    # Item 10: the user's file, line and option named.
    line = header + 200
    fields = pos_lines[line - 1].split()
    bad_h = pos_with(line, lambda s: s.replace(fields[4], "1000000000.0", 1))
    import_walk(".pos with a 1e9 m height on one line", bad_h,
                must=[f"{bad_h.name} line {line}"])
    import_walk("--align-s 1000 on a 132 s log", pos, ["--align-s", "1000"], must=["--align-s"])
    rows = imu.read_text().splitlines(keepends=True)
    bad_row = 650
    rows_nan = list(rows)
    parts = rows_nan[bad_row - 1].split(",")
    parts[4] = "nan"
    nan_imu = write(w / "imu_nan.csv", ",".join(parts))
    nan_imu.write_text("".join(rows[: bad_row - 1]) + ",".join(parts) + "".join(rows[bad_row:]))
    import_walk("IMU CSV with nan in one gyro", pos, ["--align-s", "9"],
                must=[f"imu_nan.csv line {bad_row}"], imu_file=nan_imu)
    # Item 12 / 13: times that do not increase, a BOM, fractional Q, impossible dates.
    same_t = write(w / "imu_same_t.csv", "".join(
        "1756402240.0," + ",".join(r.split(",")[1:]) for r in rows[:1300]))
    import_walk("IMU CSV whose times never increase", pos, ["--align-s", "9"],
                must=["imu_same_t.csv", "increas"], imu_file=same_t)
    q25 = pos_with(header + 10, lambda s: s.replace(" 1.0000000 25.0", " 2.5000000 25.0", 1))
    import_walk(".pos with Q = 2.5", q25, ["--align-s", "9"], must=[f"line {header + 10}"])
    feb30 = pos_with(header + 10, lambda s: "2025/02/30" + s[10:])
    import_walk(".pos dated 2025/02/30", feb30, ["--align-s", "9"], must=[f"line {header + 10}"])
    bom = write(w / "imu_bom.csv", b"\xef\xbb\xbf" + imu.read_bytes())
    code, out, _ = b.run(["import", "csv", "--imu", str(bom)] + walk_args +
                         ["--gnss", str(pos), "--align-s", "9", "--out", str(w / "bomds")])
    plain = w / "plainds"
    b.run(["import", "csv", "--imu", str(imu)] + walk_args +
          ["--gnss", str(pos), "--align-s", "9", "--out", str(plain)])
    same = code == 0 and (w / "bomds" / "imu.csv").exists() and \
        (w / "bomds" / "imu.csv").read_bytes() == (plain / "imu.csv").read_bytes()
    b.record(13, "IMU CSV with a UTF-8 BOM imports as without it",
             "accepted" if same else ("crash" if code < 0 else "weak" if code else "silent"),
             "" if same else f"exit {code}: {out.strip()[-160:]}")
    # Item 11: exit codes of bad command-line values (the README's table: 2).
    for args, must in ((["--estimate", "gyro_bias_x:0"], "gyro_bias_x:0"),
                       (["--estimate", "gyro_bias_x:1:2:1"], "gyro_bias_x:1:2:1"),
                       (["--param", "bogus=1"], "bogus"), (["--algo", "nonexistent"], "--algo"),
                       (["--window-s", "nan"], "--window-s"), (["--threads", "-1"], "--threads"),
                       (["--estimate", "no_such_effect"], "no_such_effect"),
                       (["--estimate", "gyro_bias_x:1e300"], "gyro_bias_x")):
        b.expect_error(11, "identify " + " ".join(args),
                       ["identify", "--data", str(sim), "--out", str(w / "x.json")] + args,
                       codes=(2,), must=[must])
    csv = ["import", "csv", "--imu", str(imu), "--gnss", str(pos), "--out", str(w / "c")]
    for name, args, must in (
            ("simulate --preset nope", ["simulate", "--preset", "nope", "--out", str(w / "s")],
             "nope"),
            ("import csv --columns with t twice",
             csv + ["--columns", "t,t,ax,ay,az,gx,gy,gz", "--units", "s,g,rad/s"], "--columns"),
            ("import csv --units s,furlong,rad/s",
             csv + walk_args[:2] + ["--units", "s,furlong,rad/s"], "furlong"),
            ("import csv --mounting-rpy-deg nan,0,0",
             csv + walk_args[:4] + ["--mounting-rpy-deg", "nan,0,0"], "--mounting-rpy-deg"),
            ("bench --shard 3/2", ["bench", "--preset", "quick", "--shard", "3/2", "--out",
                                   str(w / "b")], "--shard"),
            ("bench --out ''", ["bench", "--preset", "quick", "--out", ""], "--out")):
        b.expect_error(11, name, args, codes=(2,), must=[must])


def plausibility_cases(b, walk):
    """Item 14: the audit's wrong imports of the shared walk, each named in plain words (or
    refused), and the right import with no finding."""
    if not walk:
        b.skip(14, "plausibility of wrong imports", "no shared walk")
        return
    w = b.work
    imu, pos = walk / "imu_1730_sf.csv", walk / "gnss_1730_sf.pos"

    def args(units="s,g-local,rad/s", gnss=pos, mounting="180,0,-90", extra=()):
        return (["import", "csv", "--imu", str(imu), "--columns", "t,ax,ay,az,gx,gy,gz,-,-,-,-",
                 "--units", units, "--mounting-rpy-deg", mounting, "--align-s", "9", "--gnss",
                 str(gnss)] + list(extra) + ["--out", str(w / f"plaus{len(b.results)}")])

    def names(*words):
        def check(out):
            if "implausible data" not in out:
                return "no plausibility warning"
            missing = [x for x in words if x not in out]
            return f"the warning misses {missing}" if missing else ""
        return check

    b.expect_accept(14, "the walk imported right: no plausibility finding", args(),
                    check=lambda out: "a finding on the correct import" if "implausible" in out
                    else "")
    b.expect_error(14, "specific force in g declared as m/s^2", args(units="s,m/s^2,rad/s"),
                   must=["the accelerations look like g, not m/s^2"])
    b.expect_accept(14, "gyros in rad/s declared as deg/s", args(units="s,g-local,deg/s"),
                    check=names("rad/s, read as deg/s"))
    b.expect_accept(14, "the IMU clock 18 s off", args(extra=["--imu-time-offset-s", "18"]),
                    check=names("GPS-UTC leap seconds"))
    b.expect_accept(14, "a mounting 180 deg off about the roll axis", args(mounting="0,0,-90"),
                    check=names("upside down at rest"))
    lines = pos.read_text().splitlines(keepends=True)
    for label, edit, cause in (("vn and ve swapped", lambda n, e, u: (e, n, u), "swapped"),
                               ("velocities negated", lambda n, e, u: (-n, -e, -u), "negated"),
                               ("velocities in km/h", lambda n, e, u: (3.6 * n, 3.6 * e, 3.6 * u),
                                "in km/h, read as m/s")):
        out = []
        for line in lines:
            if line.startswith("%"):
                out.append(line)
                continue
            f = line.split()
            v = edit(float(f[15]), float(f[16]), float(f[17]))
            f[15:18] = [f"{x:.7f}" for x in v]
            out.append(" ".join(f) + "\n")
        edited = write(w / f"walk-{label.replace(' ', '-')}.pos", "".join(out))
        b.expect_accept(14, f".pos with {label}", args(gnss=edited), check=names(cause))


def binary_damage_cases(b, shared):
    """Item 15: damage that binary readers must read past or name (the audit's cases): stray
    bytes mid-log, a flipped byte in an unrelated ULog topic's format, one flipped bit in an IMU
    TimeMS, files cut inside and right after their definitions."""
    w = b.work
    ulog = shared / "data" / "px4-ulog" / "sample_px4_events.ulg"
    bin_log = shared / "data" / "ardupilot-copter" / "log171.bin"
    cut = ["--t-start", "74.7", "--t-end", "215"]

    def noted(*words):
        def check(out):
            missing = [x for x in words if x not in out]
            return f"no note with {missing}" if missing else ""
        return check

    if ulog.exists():
        d = ulog.read_bytes()
        half = len(d) // 2
        stray = write(w / "stray.ulg", d[:half] + b"\x01\x02\x03" + d[half:])
        b.expect_accept(15, "ULog with 3 stray bytes mid-log",
                        ["import", "ulog", str(stray), "--out", str(w / "stray-u")],
                        check=noted("damaged place(s) in the log", "bytes skipped"))
        # The formats: a flipped bit in the type of a field of 'wind' (no IMU, no GNSS).
        pos, formats, defs_end = 16, {}, None
        while pos + 3 <= len(d):
            size, kind = struct.unpack_from("<HB", d, pos)
            if chr(kind) == "F":
                formats[d[pos + 3:pos + 3 + size].split(b":")[0].decode()] = pos
            if chr(kind) in "AD":
                defs_end = pos
                break
            pos += 3 + size
        if "wind" in formats:
            at = formats["wind"] + 3 + len(b"wind:uint64_t timestamp;") + 1
            flipped = bytearray(d)
            flipped[at] ^= 0x20
            f = write(w / "format.ulg", bytes(flipped))
            b.expect_accept(15, "ULog with a flipped byte in an unrelated topic's format",
                            ["import", "ulog", str(f), "--out", str(w / "format-u")],
                            check=noted("cannot be read", f"wind (byte {formats['wind']}"))
        t1 = write(w / "cut-in-defs.ulg", d[:3000])
        b.expect_error(15, "ULog cut inside its definitions",
                       ["import", "ulog", str(t1), "--out", str(w / "cut1-u")],
                       must=["cut-in-defs.ulg", "truncated", "byte"])
        if defs_end:
            t2 = write(w / "cut-after-defs.ulg", d[:defs_end])
            b.expect_error(15, "ULog cut right after its definitions",
                           ["import", "ulog", str(t2), "--out", str(w / "cut2-u")],
                           must=["cut-after-defs.ulg", "looks truncated after its definitions"])
    else:
        b.skip(15, "ULog damage", "no shared ULog")
    if bin_log.exists():
        d = bin_log.read_bytes()
        half = len(d) // 2
        stray = write(w / "stray.bin", d[:half] + b"\x01\x02\x03" + d[half:])
        b.expect_accept(15, "DataFlash with 3 stray bytes mid-log",
                        ["import", "ardupilot", str(stray)] + cut + ["--out", str(w / "stray-a")],
                        check=noted("damaged place(s) in the log", "bytes skipped"))
        # IMU record 6000 (boot 134.775 s): bit 14 of its TimeMS moves it 16.4 s ahead, inside
        # the flight; bit 20 to 1183 s, past the log's end (the phases must not stretch to it).
        imu_id, at, k = None, 0, 0
        pos = 0
        while pos + 3 <= len(d) and k < 6000:
            if d[pos] != 0xA3 or d[pos + 1] != 0x95:
                pos += 1
                continue
            if d[pos + 2] == 128:
                if d[pos + 5:pos + 9].rstrip(b"\0") == b"IMU":
                    imu_id, imu_len = d[pos + 3], d[pos + 4]
                pos += 89
                continue
            if d[pos + 2] == imu_id:
                k += 1
                at = pos + 3
                pos += imu_len
                continue
            pos += 1
        for bit, extra, words in ((14, cut, ["TimeMS at byte", "dropped"]),
                                  (20, ["--t-start", "74.7"],
                                   ["TimeMS at byte", "airborne     85.27 - 239.14 s"])):
            flipped = bytearray(d)
            flipped[at + bit // 8] ^= 1 << (bit % 8)
            f = write(w / f"stamp{bit}.bin", bytes(flipped))
            b.expect_accept(15, f"DataFlash with bit {bit} of one IMU TimeMS flipped",
                            ["import", "ardupilot", str(f)] + extra +
                            ["--out", str(w / f"stamp{bit}-a")], check=noted(*words))
        t = write(w / "cut-after-defs.bin", d[:2937])
        b.expect_error(15, "DataFlash cut right after its FMT records",
                       ["import", "ardupilot", str(t), "--out", str(w / "cut-a")],
                       must=["cut-after-defs.bin", "looks truncated after its definitions"])
    else:
        b.skip(15, "DataFlash damage", "no shared DataFlash log")


def corruption_cases(b, shared, flips, rng):
    """Random damage to the shared binary logs: each either refused naming a byte offset, or
    imported with every dropped row counted in provenance.json (rows_read = rows_used +
    dropped) and a note printed when anything was dropped."""
    w = b.work
    logs = []
    ulog = shared / "data" / "px4-ulog" / "sample_px4_events.ulg"
    bin_log = shared / "data" / "ardupilot-copter" / "log171.bin"
    if ulog.exists():
        logs.append(("ulog", ulog, []))
    if bin_log.exists():
        logs.append(("ardupilot", bin_log, ["--t-start", "74.7", "--t-end", "215"]))
    if not logs:
        b.skip(4, "random damage to binary logs", "no shared logs")
        return
    # Each log imported intact once: a damaged copy that reads fewer IMU rows must say why.
    clean_rows = {}
    for kind, path, extra in logs:
        code, out, _ = b.run(["import", kind, str(path)] + extra + ["--out", str(w / "intact")])
        if code == 0:
            prov = json.loads((w / "intact" / "provenance.json").read_text())
            clean_rows[kind] = prov.get("imu", {}).get("rows_read")
        shutil.rmtree(w / "intact", ignore_errors=True)
    for k in range(flips):
        kind, path, extra = logs[k % len(logs)]
        data = bytearray(path.read_bytes())
        at = rng.randrange(64, len(data) - 8)
        width = rng.choice((1, 5))
        for i in range(width):
            data[at + i] ^= 1 << rng.randrange(8)
        damaged = write(w / f"damaged{k}{path.suffix}", bytes(data))
        out_dir = w / f"damaged{k}"
        code, out, _ = b.run(["import", kind, str(damaged)] + extra + ["--out", str(out_dir)])
        name = f"{kind} with {width} byte(s) flipped at {at}"
        if code < 0 or code > 2:
            b.record(4, name, "crash", f"exit {code}")
        elif code != 0:
            clear = "byte" in out or "record" in out or "message" in out
            if out_dir.exists() and any(out_dir.iterdir()):
                b.record(4, name, "lost", "an error, yet files were written")
            else:
                b.record(4, name, "clear" if clear else "weak", out.strip().splitlines()[-1][:160])
        elif not (out_dir / "provenance.json").exists():
            b.record(4, name, "silent", "exit 0 without provenance.json")
        else:
            prov = json.loads((out_dir / "provenance.json").read_text())
            imu = prov.get("imu", {})
            dropped = sum(v for v in imu.get("rows_dropped", {}).values()
                          if isinstance(v, int))
            read = imu.get("rows_read")
            used = imu.get("rows_used")
            accounted = read is None or used is None or read == used + dropped
            noted = dropped == 0 or "note" in out.lower() or "dropped" in out
            # Rows lost to skipped damage are not "dropped": the damage must be said instead.
            lost_rows = read is not None and kind in clean_rows and read < clean_rows[kind]
            said = not lost_rows or any(x in out for x in (
                "damaged place", "truncat", "timestamp jump"))
            ok = accounted and noted and said
            b.record(4, name, "accepted" if ok else "silent",
                     "" if ok else f"rows_read {read} (intact {clean_rows.get(kind)}), used {used}, "
                     f"dropped {dropped}, damage said: {said}")
        damaged.unlink()
        shutil.rmtree(out_dir, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    root = Path(__file__).resolve().parent.parent
    parser.add_argument("--insid", default=str(root / "build" / "cli" / "insid"))
    parser.add_argument("--shared", default=str(root.parent / "shared"))
    parser.add_argument("--random-flips", type=int, default=400)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", help="write the cases and verdicts here")
    args = parser.parse_args()
    shared = Path(args.shared).resolve()
    walk = shared / "data" / "rtklib-walk"
    walk = walk if (walk / "imu_1730_sf.csv").exists() else None
    with tempfile.TemporaryDirectory(prefix="insid-battery-") as tmp:
        b = Battery(str(Path(args.insid).resolve()), shared, Path(tmp))
        sim = b.work / "sim"
        code, out, _ = b.run(["simulate", "--preset", "straight", "--flight-s", "30", "--seed",
                              "1", "--out", str(sim)])
        if code != 0:
            sys.exit(f"hostile_battery: simulate failed: {out}")
        ownership_cases(b, sim, walk)
        round_three_ownership_cases(b, sim)
        campaign_cases(b)
        json_cases(b, sim)
        external_cases(b, sim)
        reader_cases(b, sim, walk, shared)
        plausibility_cases(b, walk)
        binary_damage_cases(b, shared)
        corruption_cases(b, shared, args.random_flips, random.Random(args.seed))
    counts = {}
    for _, _, verdict, _ in b.results:
        counts[verdict] = counts.get(verdict, 0) + 1
    print("\n" + ", ".join(f"{n} {v}" for v, n in sorted(counts.items())) +
          f" ({len(b.results)} cases)")
    if args.json:
        Path(args.json).write_text(json.dumps(
            [{"item": i, "case": n, "verdict": v, "detail": d} for i, n, v, d in b.results],
            indent=1))
    bad = {v for v in counts if v not in ("clear", "accepted", "skipped")}
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
