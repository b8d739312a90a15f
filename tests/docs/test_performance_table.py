#!/usr/bin/python3
"""docs/performance.md's generated table is what scripts/performance_table.py makes of the CSVs.

Copies docs/performance.md to a temporary folder, regenerates the table there and compares the two
files: any difference (a CSV committed without regenerating the table, a hand edit inside the
markers) fails, with the difference and the command that fixes it. Skipped (exit 77) outside a git
checkout, where the CSVs have no commit to be dated by."""
import argparse
import difflib
import os
import shutil
import subprocess
import sys
import tempfile


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source", required=True, help="the repository's top folder")
    args = parser.parse_args()
    if subprocess.run(["git", "-C", args.source, "rev-parse", "--git-dir"], capture_output=True).returncode != 0:
        print(f"SKIPPED: {args.source} is not a git checkout")
        return 77
    # A shallow clone lacks the commits that dated the CSVs: the table cannot be regenerated there.
    shallow = subprocess.run(["git", "-C", args.source, "rev-parse", "--is-shallow-repository"],
                             capture_output=True, text=True).stdout.strip()
    if shallow == "true":
        print(f"SKIPPED: {args.source} is a shallow clone (the CSVs' commits are not in it)")
        return 77
    doc = os.path.join(args.source, "docs", "performance.md")
    with tempfile.TemporaryDirectory() as folder:
        copy = os.path.join(folder, "performance.md")
        shutil.copyfile(doc, copy)
        subprocess.run([sys.executable, os.path.join(args.source, "scripts", "performance_table.py"), "--doc", copy],
                       check=True)
        with open(doc) as f:
            committed = f.read().splitlines()
        with open(copy) as f:
            generated = f.read().splitlines()
    if committed == generated:
        print("ok     docs/performance.md's table is what scripts/performance_table.py makes of the CSVs")
        return 0
    print("\n".join(difflib.unified_diff(committed, generated, "docs/performance.md", "regenerated", lineterm="")))
    print("FAILED docs/performance.md's table is stale: run scripts/performance_table.py and commit the table")
    return 1


if __name__ == "__main__":
    sys.exit(main())
