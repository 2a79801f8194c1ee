#!/usr/bin/env python3
"""Signposts test: every file, section and command that README.md, DEVELOPERS.md, spec/ and docs/
name exists.

- a repository path (lib/..., spec/..., tools/..., tests/..., docs/..., shaders/..., fuzz/...,
  cmake/...) written in backticks or as a markdown link target exists in the tree;
- a section reference "§N" or "§N.M" names a numbered heading of the document it points into:
  the markdown file written just before it on the same line ("format.md §5.1", "spec/dag.md §7"),
  else the document it is written in;
- a command written as `vgeo NAME ...` is one of the CLI's commands (`vgeo --help`);
- a source comment (lib/, tools/, tests/, shaders/, fuzz/, cmake/) cites no document outside the
  repository: "lessons" or "issue N" is a miss unless it is the path of a docs/acceptance/ file
  that exists (a comment states its reason itself or points at spec/ or docs/).

usage: signposts.py REPO_ROOT VGEO_BINARY          exit 0 when all hold, 1 with one line per miss.
       signposts.py --self-test VGEO_BINARY          the checker fires on a tree with one planted
                                                     miss of each kind (exit 0 when it does).
"""
import os
import re
import subprocess
import sys

ROOTS = ("lib", "spec", "tools", "tests", "docs", "shaders", "fuzz", "cmake", ".ci")
PATH_RE = re.compile(r"(?<![\w./-])((?:%s)/[A-Za-z0-9_./*<>{}-]*[A-Za-z0-9_*>}])" % "|".join(re.escape(r) for r in ROOTS))
DOC_RE = re.compile(r"([A-Za-z0-9_./-]+\.md)\b")
SECTION_RE = re.compile(r"§\s?(\d+[a-z]?(?:\.\d+)*)")
HEADING_RE = re.compile(r"^#+\s+(?:§\s?)?(\d+[a-z]?(?:\.\d+)*)[.)]?\s")
CHAIN_RE = re.compile(r"^(?:\s|,|–|—|-|\)|\]|`|\band\b|\bor\b)*$")
LIST_ITEM_RE = re.compile(r"^\s{0,3}(\d+)\.\s")
COMMAND_RE = re.compile(r"`vgeo ([a-z][a-z-]*)")
# Placeholders, not paths: "lib/vgeo/<stage>/", "tests/<stage>/*.cpp", "spec/vectors/lod/N".
PLACEHOLDER = re.compile(r"[<>*{}]|/N$|/X$")
SOURCE_ROOTS = ("lib", "tools", "tests", "shaders", "fuzz", "cmake")
SLASH_COMMENT_EXTS = (".h", ".hpp", ".c", ".cc", ".cpp", ".comp", ".glsl", ".vert", ".frag")
HASH_COMMENT_EXTS = (".py", ".sh", ".cmake")
# Citations of the notes file kept outside the repository, or of a tracker entry by number:
# neither is in the tree.
CITATION_RE = re.compile(r"(?<!\w)(?:lessons?\b|issue ?#?\d+)", re.IGNORECASE)
ACCEPTANCE_DIR = "docs/acceptance/"


def documents(root):
    """docs/acceptance/ is left out: its files are dated records of measurements at a named commit
    (a file retired since, a section of the issue they answer), not signposts to today's tree."""
    docs = [os.path.join(root, f) for f in ("README.md", "DEVELOPERS.md")]
    for top in ("spec", "docs"):
        for d, dirs, files in os.walk(os.path.join(root, top)):
            dirs[:] = sorted(x for x in dirs if os.path.join(d, x) != os.path.join(root, "docs", "acceptance"))
            docs += [os.path.join(d, f) for f in sorted(files) if f.endswith(".md")]
    return [d for d in docs if os.path.exists(d)]


def numbered_sections(path):
    """Numbered headings, plus "N.k" for the k-th numbered step of a top-level list in section N
    ("§2.3" is step 3 of "## 2. Build algorithm")."""
    found = set()
    in_code = False
    current = None
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("```"):
                in_code = not in_code
            if in_code:
                continue
            m = HEADING_RE.match(line)
            if m:
                found.add(m.group(1))
                current = m.group(1)
                continue
            if line.startswith("#"):
                current = None
                continue
            m = LIST_ITEM_RE.match(line)
            if m and current:
                found.add("%s.%s" % (current, m.group(1)))
    return found


def cli_commands(binary):
    out = subprocess.run([binary, "--help"], capture_output=True, text=True).stdout
    names = set()
    in_list = False
    for line in out.splitlines():
        if re.match(r"^\S.*:\s*$", line):  # "SUBCOMMANDS:" / "Subcommands:"
            in_list = "ubcommand" in line or "UBCOMMAND" in line
            continue
        m = re.match(r"^\s+([a-z][a-z-]*)\b", line)
        if in_list and m:
            names.add(m.group(1))
    return names


def comment_part(line, hash_comments):
    """The comment text of a source line ("" when it has none); a string that happens to hold
    the comment marker adds text to scan, never hides a comment."""
    if hash_comments:
        at = line.find("#")
        return line[at:] if at >= 0 else ""
    stripped = line.lstrip()
    if stripped.startswith("/*") or stripped.startswith("*"):
        return stripped
    at = line.find("//")
    return line[at:] if at >= 0 else ""


def source_files(root):
    for top in SOURCE_ROOTS:
        for d, dirs, files in os.walk(os.path.join(root, top)):
            dirs.sort()
            for f in sorted(files):
                path = os.path.join(d, f)
                if f.endswith(SLASH_COMMENT_EXTS):
                    yield path, False
                elif f.endswith(HASH_COMMENT_EXTS) or f == "CMakeLists.txt":
                    yield path, True
                elif "." not in f:
                    with open(path, "rb") as script:
                        if script.read(2) == b"#!":
                            yield path, True


def check_comment_citations(root):
    misses = []
    for path, hash_comments in source_files(root):
        rel = os.path.relpath(path, root)
        with open(path, encoding="utf-8", errors="replace") as f:
            for number, line in enumerate(f, 1):
                comment = comment_part(line, hash_comments)
                for m in CITATION_RE.finditer(comment):
                    if comment[:m.start()].endswith(ACCEPTANCE_DIR):
                        name = re.match(r"[\w.-]*\w", comment[m.start():]).group(0)
                        if os.path.exists(os.path.join(root, ACCEPTANCE_DIR, name)):
                            continue
                        misses.append("%s:%d: names %s%s, which does not exist" % (rel, number, ACCEPTANCE_DIR, name))
                        continue
                    misses.append("%s:%d: comment cites \"%s\", a document not in the repository (state the "
                                  "reason, or name a spec/ or docs/ file)" % (rel, number, m.group(0)))
    return misses


def resolve_doc(current, named, root):
    """The document a § reference points into."""
    if not named:
        return current
    for base in (os.path.dirname(current), os.path.join(root, "spec"), root):
        candidate = os.path.normpath(os.path.join(base, named))
        if os.path.exists(candidate):
            return candidate
    return None


def self_test(binary):
    """A known-bad tree: one missing path, one missing section, one unknown command, and one of each
    that is fine; the checker must report exactly the three planted misses."""
    import tempfile
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "spec"))
        with open(os.path.join(root, "spec", "a.md"), "w", encoding="utf-8") as f:
            f.write("# A\n\n## 1. One\n\n1. first step\n\nSee spec/a.md and §1.1; `vgeo verify x`.\n"
                    "Planted: spec/missing.md names, §2 of this file, `vgeo nosuch`.\n")
        with open(os.path.join(root, "README.md"), "w", encoding="utf-8") as f:
            f.write("# R\n\nspec/a.md §1 holds.\n")
        os.makedirs(os.path.join(root, "lib"))
        os.makedirs(os.path.join(root, "docs", "acceptance"))
        open(os.path.join(root, "docs", "acceptance", "issue1.md"), "w").close()
        with open(os.path.join(root, "lib", "a.cpp"), "w", encoding="utf-8") as f:
            f.write("// Fine: measured in docs/acceptance/issue1.md; max_issues = 8;\n"
                    "const char* k = \"issue9.ply\";  // a data file in a string, not a citation\n"
                    "// Planted: see Lessons item 6,\n"
                    "int x;  // planted too (issue 12)\n"
                    "// and docs/acceptance/issue2.md, which is not there.\n")
        with open(os.path.join(root, "lib", "b.py"), "w", encoding="utf-8") as f:
            f.write("x = 1  \x23 planted: issue \x237\n")  # \x23: a literal one would be a comment here
        misses = check(root, binary)
    expected = ["spec/a.md:8: names spec/missing.md", "spec/a.md:8: names §2 of spec/a.md",
                "spec/a.md:8: names `vgeo nosuch`", "lib/a.cpp:3: comment cites \"Lessons\"",
                "lib/a.cpp:4: comment cites \"issue 12\"", "lib/a.cpp:5: names docs/acceptance/issue2.md",
                "lib/b.py:1: comment cites \"issue #7\""]
    got = [m for m in misses if any(m.startswith(e) for e in expected)]
    if len(misses) != len(expected) or len(got) != len(expected):
        print("signposts self-test: expected the %d planted misses, got:" % len(expected))
        for m in misses:
            print("  " + m)
        return 1
    print("signposts self-test: the %d planted misses are reported" % len(expected))
    return 0


def main():
    if sys.argv[1] == "--self-test":
        return self_test(sys.argv[2])
    misses = check(sys.argv[1], sys.argv[2])
    for miss in misses:
        print(miss)
    print("signposts: %d miss(es)" % len(misses))
    return 1 if misses else 0


def check(root, binary):
    commands = cli_commands(binary)
    if not commands:
        return ["signposts: no command list in `%s --help`" % binary]
    misses = []
    sections = {}
    for doc in documents(root):
        rel = os.path.relpath(doc, root)
        in_code = False
        carried_doc = None
        with open(doc, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                if line.startswith("```"):
                    in_code = not in_code
                    carried_doc = None
                where = "%s:%d" % (rel, number)
                for m in PATH_RE.finditer(line):
                    path = m.group(1).rstrip(".")
                    if PLACEHOLDER.search(path):
                        continue
                    if not os.path.exists(os.path.join(root, path)):
                        misses.append("%s: names %s, which does not exist" % (where, path))
                if in_code:
                    continue
                # A § refers to the document named right before it ("spec/gpu.md §10", "format.md
                # §3–§4", "dag.md §6 and §7"), else to the document it is written in.
                marks = [(m.start(), m.end(), "doc", m.group(1)) for m in DOC_RE.finditer(line)]
                marks += [(m.start(), m.end(), "section", m.group(1)) for m in SECTION_RE.finditer(line)]
                # A line that starts with § continues the reference the previous line ended with.
                previous_end, previous_doc = (0, carried_doc) if carried_doc else (None, None)
                for start, end, kind, value in sorted(marks):
                    gap = line[previous_end:start] if previous_end is not None else None
                    chained = gap is not None and CHAIN_RE.match(gap)
                    if kind == "doc":
                        previous_end, previous_doc = end, value
                        continue
                    named = previous_doc if chained else None
                    previous_end, previous_doc = end, named
                    target = resolve_doc(doc, named, root)
                    if target is None:
                        misses.append("%s: names %s, which does not exist" % (where, named))
                        continue
                    if target not in sections:
                        sections[target] = numbered_sections(target)
                    if value not in sections[target]:
                        misses.append("%s: names §%s of %s, which has no such section"
                                      % (where, value, os.path.relpath(target, root)))
                carried_doc = previous_doc if previous_end is not None and CHAIN_RE.match(line[previous_end:]) else None
                for m in COMMAND_RE.finditer(line):
                    if m.group(1) not in commands:
                        misses.append("%s: names `vgeo %s`, which is not a command" % (where, m.group(1)))
    return misses + check_comment_citations(root)


if __name__ == "__main__":
    sys.exit(main())
