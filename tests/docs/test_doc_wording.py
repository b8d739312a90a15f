#!/usr/bin/python3
"""The project's files state the project, not how its work was organised, and README.md stays short.

Fails on a Markdown file of the tree (node_modules, .git and build folders left out), or on any other
text file git tracks (source, tests, .prm, .csv, CMakeLists, scripts), that
  - speaks of a session of work: an ordinal before "session" ("the twentieth session",
    "twenty-second session", "22nd session") or "this/last/previous/earlier/next/later session";
    a session of the domain ("a scripted session", "the haptic session", "the default session",
    "session.csv", "a two-hand session", "the session's trace") is not one;
  - names an issue by its number ("issue 36", "issue #36", "issues 12 and 13");
and on a top-level README.md over 150 lines or with a paragraph over 90 words (fenced code, tables
and headings are not paragraphs; each list item is one). This file alone is left out: its examples
must name what the rules flag. A file that is not UTF-8 text (an image, a .mrt) is not read.

Before reading the tree it checks its own rules on synthetic text, both ways, so that a rule that
can no longer fail fails the test. Python 3 standard library only."""
import argparse
import os
import re
import subprocess
import sys

README_MAX_LINES = 150
PARAGRAPH_MAX_WORDS = 90

_UNITS = "first|second|third|fourth|fifth|sixth|seventh|eighth|ninth"
_TEENS = ("tenth|eleventh|twelfth|thirteenth|fourteenth|fifteenth|sixteenth|seventeenth|eighteenth|"
          "nineteenth")
_TENS = "twentieth|thirtieth|fortieth|fiftieth"
_ORDINAL = (rf"(?:(?:twenty|thirty|forty|fifty)[- ](?:{_UNITS})|{_TENS}|{_TEENS}|{_UNITS}"
            r"|\d+(?:st|nd|rd|th))")
WORK_SESSION = re.compile(
    rf"\b(?:{_ORDINAL}|this|last|previous|earlier|next|later)\s+sessions?\b", re.IGNORECASE)
# "the eleventh to seventeenth sessions": the second ordinal is caught by the rule above.
ISSUE_NUMBER = re.compile(r"\bissues?\s+#?\d+|\bissue\s+#\s*\d+", re.IGNORECASE)

SKIPPED_FOLDERS = {"node_modules", ".git"}
# The one file that must name what the rules flag: its docstring and its synthetic examples.
OWN_PATH = os.path.join("tests", "docs", "test_doc_wording.py")


# ------------------------------------------------------------------------------------------------
# The rules
# ------------------------------------------------------------------------------------------------
def wording_findings(text):
    """(line number, words) of each place where `text` speaks of a work session or an issue number."""
    findings = []
    for number, line in enumerate(text.splitlines(), 1):
        for rule in (WORK_SESSION, ISSUE_NUMBER):
            findings += [(number, match.group(0)) for match in rule.finditer(line)]
    return findings


def paragraphs(text):
    """(first line number, text) of each paragraph: fenced code, tables and headings left out, each list
    item a paragraph of its own."""
    found, current, start, in_code = [], [], 0, False

    def close():
        if current:
            found.append((start, " ".join(current)))
            current.clear()

    for number, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        if stripped.startswith("```"):
            close()
            in_code = not in_code
            continue
        if in_code or not stripped or stripped.startswith(("|", "#", "![")):
            close()
            continue
        if re.match(r"([-*+]|\d+\.)\s", stripped):
            close()
        if not current:
            start = number
        current.append(stripped)
    close()
    return found


def readme_findings(text):
    """What makes a README too long to read in five minutes: its line count, its long paragraphs."""
    findings = []
    lines = len(text.splitlines())
    if lines > README_MAX_LINES:
        findings.append((lines, f"{lines} lines (at most {README_MAX_LINES})"))
    for start, paragraph in paragraphs(text):
        words = len(paragraph.split())
        if words > PARAGRAPH_MAX_WORDS:
            findings.append((start, f"a paragraph of {words} words (at most {PARAGRAPH_MAX_WORDS})"))
    return findings


# ------------------------------------------------------------------------------------------------
# The rules checked on synthetic text, both ways
# ------------------------------------------------------------------------------------------------
FLAGGED = [
    "measured in the twentieth session", "the twenty-second session's change", "Twenty first session",
    "this session's figures", "as the last session found", "from a previous session",
    "in earlier sessions", "the next session will", "a later session", "the 22nd session",
    "the eleventh to seventeenth sessions", "see issue 36", "issue #36, item 5",
    "issues 12 and 13", "Issue 39's findings", "(issue 20)",
    "// Restarts (issue 39): the counter", "# The distributed path (issue 7): mpirun",
    "f577952 (before issue 37's look-ahead),", "// in a second session two HIPs slide",
]
NOT_FLAGGED = [
    "a scripted session", "the haptic session at 1 kHz", "the default session's slide",
    "parameters/ribbed_panel_session.csv", "a two-hand session", "the session's trace",
    "a new device session mid-press", "in both sessions (1 and 4 kHz)", "a long random session",
    "the session ends here", "--session FILE", "the issue of stability", "an issue with 36 nodes",
    "the #1d2026 background", "issued 36 times",
    "modalrt_kernel_begin_session(kernel);", "std::size_t issue_36 = 0;", "// in a second scripted session",
    "slide_session = R\"(time,hip,event", "set Session file = parameters/ribbed_panel_session.csv",
]


def self_check():
    """The failures of the rules on the synthetic text; empty when every rule can fail and pass."""
    failures = [f"not flagged: {text!r}" for text in FLAGGED if not wording_findings(text)]
    failures += [f"flagged: {text!r}: {wording_findings(text)}" for text in NOT_FLAGGED if wording_findings(text)]
    short = "# Title\n\nA short paragraph.\n\n```\n" + "code " * 200 + "\n```\n| " + "cell " * 200 + "|\n"
    if readme_findings(short):
        failures.append(f"a short README flagged: {readme_findings(short)}")
    long_paragraph = "# Title\n\n" + "word " * 60 + "\n" + "word " * 40 + "\n"
    if not readme_findings(long_paragraph):
        failures.append("a paragraph of 100 words over two lines not flagged")
    list_items = "".join(f"- item {i} " + "word " * 50 + "\n" for i in range(5))
    if readme_findings(list_items):
        failures.append("five list items of 52 words each flagged as one paragraph")
    if not readme_findings("- line\n" * (README_MAX_LINES + 1)):
        failures.append(f"a README of {README_MAX_LINES + 1} lines not flagged")
    if readme_findings("- line\n" * README_MAX_LINES):
        failures.append(f"a README of {README_MAX_LINES} lines flagged")
    return failures


# ------------------------------------------------------------------------------------------------
# The tree
# ------------------------------------------------------------------------------------------------
def is_build_folder(path, names):
    return os.path.basename(path).startswith("build") or "CMakeCache.txt" in names


def tree_files(top):
    """Relative paths of the tree's files, node_modules, .git and build folders left out."""
    for folder, subfolders, names in os.walk(top):
        subfolders[:] = sorted(d for d in subfolders if d not in SKIPPED_FOLDERS
                               and not is_build_folder(os.path.join(folder, d),
                                                       os.listdir(os.path.join(folder, d))))
        for name in sorted(names):
            yield os.path.relpath(os.path.join(folder, name), top)


def tracked_files(top):
    """The files git tracks under `top`, relative to it; None where `top` is no git checkout (a source
    archive), whose every file is then read."""
    try:
        listing = subprocess.run(["git", "-C", top, "ls-files", "-z"], capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    return [name for name in listing.decode("utf-8", "replace").split("\0") if name]


def text_of(path):
    """The file's text, or None when it is not UTF-8 text (NUL bytes or undecodable)."""
    with open(path, "rb") as f:
        data = f.read()
    if b"\0" in data:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


def files_to_check(top):
    """Relative paths: every Markdown file of the tree and every tracked file, this file left out."""
    in_tree = list(tree_files(top))
    tracked = tracked_files(top)
    if tracked is None:
        tracked = in_tree
    markdown = {name for name in in_tree if name.endswith(".md")}
    tracked = {name for name in tracked if os.path.isfile(os.path.join(top, name))}
    return sorted((markdown | tracked) - {OWN_PATH})


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source", required=True, help="the repository's top folder")
    args = parser.parse_args()
    failures = self_check()
    if failures:
        print("FAILED the rules themselves:\n  " + "\n  ".join(failures))
        return 1
    relatives = files_to_check(args.source)
    if not any(name.endswith((".cc", ".h", ".py")) for name in relatives):
        print(f"FAILED no source file found under {args.source}: is it the repository's top folder?")
        return 1
    problems = []
    for relative in relatives:
        text = text_of(os.path.join(args.source, relative))
        if text is None:
            continue
        problems += [f"{relative}:{line}: '{words}'" for line, words in wording_findings(text)]
        if relative == "README.md":
            problems += [f"{relative}:{line}: {what}" for line, what in readme_findings(text)]
    if problems:
        print("\n".join(problems))
        print(f"FAILED {len(problems)} places: a file states the project as it is (no work sessions, no issue "
              f"numbers); README.md at most {README_MAX_LINES} lines, paragraphs at most {PARAGRAPH_MAX_WORDS} words")
        return 1
    print(f"ok     none of {len(relatives)} files speaks of work sessions or issue numbers; README.md is short")
    return 0


if __name__ == "__main__":
    sys.exit(main())
