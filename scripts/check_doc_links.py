#!/usr/bin/python3
"""Every relative link of README.md and docs/*.md resolves (the README links into docs/, and
links must not rot). Run by ctest as `doc_links`.

Usage: /usr/bin/python3 scripts/check_doc_links.py [--paths] [FILE.md ...]
  (default files: README.md, docs/*.md, results/README.md)
Checks every Markdown link `[text](target)` that is not a URL: the file or folder exists,
relative to the linking file, and a `#anchor` names a heading of the target (GitHub's slugs).
With --paths it also lists the repository paths written in backticks (`nav/fitness.h`,
`results/window/`) that do not exist, relative to the repository root, as the documents write
them; those are printed as warnings and do not fail the check (files move between folders while
their documents follow).
It also holds README.md to at most 400 lines (the user's guide; reference goes to
docs/).
Exit 0 when every link resolves and the README is within its length, 1 otherwise.
"""
import glob
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINK = re.compile(r"(?<!!)\[([^\]]*)\]\(([^)\s]+)\)")
TICK = re.compile(r"`([^`\s]+)`")
TOP = None
README_MAX_LINES = 400


def slug(heading):
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def anchors(path):
    out, code = set(), False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("```"):
                code = not code
            elif not code and line.startswith("#"):
                out.add(slug(line.lstrip("#")))
    return out


def text_outside_code(path):
    code = False
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if line.startswith("```"):
                code = not code
                continue
            if not code:
                yield n, line


def main(argv):
    global TOP
    paths = "--paths" in argv
    files = [a for a in argv if a != "--paths"] or (
        ["README.md"] + sorted(glob.glob("docs/*.md", root_dir=ROOT)) + ["results/README.md"])
    TOP = {e for e in os.listdir(ROOT) if os.path.isdir(os.path.join(ROOT, e)) and e[0] != "."}
    bad, warned, links = 0, 0, 0
    for rel in files:
        path = os.path.join(ROOT, rel)
        for n, line in text_outside_code(path):
            for _, target in LINK.findall(line):
                if re.match(r"^[a-z]+:", target):
                    continue
                links += 1
                file_part, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) if file_part else path
                if not os.path.exists(dest):
                    print(f"{rel}:{n}: broken link: {target} ({os.path.relpath(dest, ROOT)} does not exist)")
                    bad += 1
                elif anchor and dest.endswith(".md") and anchor not in anchors(dest):
                    print(f"{rel}:{n}: broken link: {target} (no heading '#{anchor}' in {os.path.relpath(dest, ROOT)})")
                    bad += 1
            if paths:
                for tok in TICK.findall(line):
                    tok = tok.rstrip(".,:;)")
                    first = tok.split("/")[0]
                    if "/" not in tok or first not in TOP or re.search(r"[*<>{}|$\[]", tok):
                        continue
                    if not os.path.exists(os.path.join(ROOT, tok)):
                        print(f"{rel}:{n}: warning: `{tok}` does not exist")
                        warned += 1
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        readme_lines = sum(1 for _ in f)
    if readme_lines > README_MAX_LINES:
        print(f"check_doc_links: README.md has {readme_lines} lines, over its {README_MAX_LINES}: "
              "move reference material into docs/ and link it")
        bad += 1
    print(f"check_doc_links: {links} links in {len(files)} files, {bad} problems; README.md "
          f"{readme_lines} lines (at most {README_MAX_LINES})"
          + (f"; {warned} backticked paths not found (warnings)" if paths else ""))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
