#!/usr/bin/env python3
"""Instruction sets stay where they belong in the one `insid` program (kernel/batch_kernel.h).

Under CPU dispatch the program is baseline x86-64 except the batched kernel's AVX-512 and AVX2
paths. This disassembles the linked program and checks that
  - no function outside insid::kernel_avx512 / insid::kernel_avx2 holds an instruction beyond the
    baseline (a VEX/EVEX-encoded instruction, a ymm/zmm or mask register): an inline function of a
    header compiled for a kernel path and kept by the linker for the whole program would show up
    here, and would crash the program on a CPU without that path;
  - the avx512 path is AVX-512 (zmm registers), the avx2 path AVX2 + FMA (ymm, vfmadd) without
    AVX-512, the baseline path has no VEX instruction: a path whose instruction set was silently
    dropped fails.

Usage: test_kernel_isa.py OBJDUMP PROGRAM      (exit 0 = pass; ctest `kernel_isa_confined`)
"""
import re
import subprocess
import sys

FUNC = re.compile(r"^[0-9a-f]+ <(.+)>:$")
# AT&T syntax: VEX/EVEX instructions are the v-prefixed mnemonics (but not verr/verw).
BEYOND = re.compile(r"^\s*[0-9a-f]+:\s+(v(?!err|erw)[a-z0-9]+)\b|%[yz]mm\d+|%k[1-7]\b")


def main():
    objdump, program = sys.argv[1], sys.argv[2]
    out = subprocess.run([objdump, "-d", "--no-show-raw-insn", "-C", program], check=True,
                         capture_output=True, text=True).stdout
    leaks = {}
    seen = {"avx512": set(), "avx2": set(), "baseline": set()}
    path_functions = {"avx512": 0, "avx2": 0, "baseline": 0}
    func = None
    path = None
    for line in out.splitlines():
        m = FUNC.match(line)
        if m:
            func = m.group(1)
            path = None
            for p in path_functions:
                if f"insid::kernel_{p}::" in func:
                    path = p
                    path_functions[p] += 1
            continue
        if func is None or not BEYOND.search(line):
            continue
        if path is None:
            leaks.setdefault(func, line.strip())
            continue
        if "%zmm" in line:
            seen[path].add("zmm")
        if "%ymm" in line:
            seen[path].add("ymm")
        if re.search(r"\bvfn?m(add|sub)", line):
            seen[path].add("fma")
        seen[path].add("vex")
    failures = []
    if leaks:
        failures.append(f"{len(leaks)} functions outside the kernel paths use instructions beyond "
                        "x86-64 (first 10, with one instruction each):")
        failures += [f"  {f}: {i}" for f, i in list(leaks.items())[:10]]
    for p, n in path_functions.items():
        if n == 0:
            failures.append(f"no function of insid::kernel_{p} in the program")
    if "zmm" not in seen["avx512"]:
        failures.append("the avx512 path has no zmm instruction")
    if not {"ymm", "fma"} <= seen["avx2"] or "zmm" in seen["avx2"]:
        failures.append(f"the avx2 path is not AVX2 + FMA without AVX-512: {sorted(seen['avx2'])}")
    if seen["baseline"]:
        failures.append(f"the baseline path uses {sorted(seen['baseline'])}")
    if failures:
        print("FAIL:\n" + "\n".join(failures))
        return 1
    print(f"{program}: instructions beyond x86-64 only in the kernel paths "
          f"(functions: {path_functions}); avx512 uses {sorted(seen['avx512'])}, "
          f"avx2 {sorted(seen['avx2'])}, baseline none")
    return 0


if __name__ == "__main__":
    sys.exit(main())
