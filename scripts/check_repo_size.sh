#!/usr/bin/env bash
# The repository stays lean: fails when the tracked files of results/ pass their limit
# (12 MB) or all tracked files pass theirs (15 MB), so that a clone is quick and the tree can be
# copied where a copy is limited to 64 MiB. MB = 1,000,000 bytes. Sizes are those of the files
# as git tracks them (the index: committed or staged), not of build outputs or ignored files.
#   scripts/check_repo_size.sh [--results-mb N] [--total-mb N]
# Run by ctest (`repo_size`), hence by scripts/test.sh and CI; exit 77 (skipped) outside a git
# checkout. How a result is made to fit: results/README.md, "What is committed, and how"
# (scripts/pack_results.py).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
results_mb=12
total_mb=15
while [ $# -gt 0 ]; do
  case "$1" in
    --results-mb) results_mb="$2"; shift 2 ;;
    --total-mb) total_mb="$2"; shift 2 ;;
    *) echo "check_repo_size: unknown argument '$1' (--results-mb N, --total-mb N)" >&2; exit 2 ;;
  esac
done
if ! git -C "$root" rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  echo "check_repo_size: skipped: $root is not a git checkout"
  exit 77
fi
# "size path" for every tracked blob (gitlinks of submodules have no blob here: left out).
list="$(mktemp)"
trap 'rm -f "$list"' EXIT
git -C "$root" -c core.quotepath=off ls-files -s | awk -F'\t' '$1 !~ /^160000 / {
    split($1, a, " "); print a[2] " " $2 }' > "$list"
cut -d' ' -f1 "$list" | git -C "$root" cat-file --batch-check='%(objectsize)' |
  paste -d' ' - <(cut -d' ' -f2- "$list") |
  awk -v rlim="$results_mb" -v tlim="$total_mb" '
    { total += $1; n++
      if (index($2, "results/") == 1) { results += $1; rn++
        split($2, p, "/"); dir[p[2]] += $1 } }
    END {
      printf "check_repo_size: all tracked files %.2f MB (%d files), limit %g MB\n", total / 1e6, n, tlim
      printf "check_repo_size: results/ %.2f MB (%d files), limit %g MB\n", results / 1e6, rn, rlim
      for (d in dir) printf "  results/%-24s %8.2f MB\n", d, dir[d] / 1e6 | "sort -k2 -rn"
      close("sort -k2 -rn")
      bad = 0
      if (results > rlim * 1e6) {
        printf "check_repo_size: FAIL: results/ is %.2f MB, over its %g MB limit: pack the new results (scripts/pack_results.py; results/README.md, \"What is committed, and how\") or leave bulk out\n", results / 1e6, rlim
        bad = 1 }
      if (total > tlim * 1e6) {
        printf "check_repo_size: FAIL: the tracked files are %.2f MB, over the %g MB limit\n", total / 1e6, tlim
        bad = 1 }
      if (!bad) print "check_repo_size: within the limits"
      exit bad }'
