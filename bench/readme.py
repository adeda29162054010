"""Re-measure the README's benchmark table: run every benchmark and rewrite the table.

    scripts/run python bench/readme.py [--quick]

Runs each command below with ``--markdown``, gathers the rows it prints and writes them,
each with the command that produced it, between the ``<!-- bench:begin -->`` and
``<!-- bench:end -->`` markers of README.md. ``--quick`` uses fewer runs and smaller
workloads (for a check that the table can be made, not for figures to quote);
``--only a.py,b.py`` re-runs only those benchmarks and keeps the other rows as they are.
"""

from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BEGIN, END = "<!-- bench:begin -->", "<!-- bench:end -->"

# (command as documented, extra arguments for --quick)
COMMANDS = [
    ("bench/bench_bake.py", ["--runs", "1", "--skip-8k"]),
    ("bench/bench_blender.py", ["--runs", "1", "--size", "512"]),
    ("bench/bench_unwrap.py", ["--runs", "1", "--only", "gear"]),
    ("bench/bench_textures.py", ["--runs", "1", "--points", "500000"]),
    ("bench/bench_service.py", ["--jobs", "4", "--uploads", "4"]),
    ("bench/bench_error.py", ["--sizes", "256", "--repeats", "1", "--textures", "marble"]),
    ("bench/bench_swatch.py", ["--requests", "5"]),
    ("bench/bench_material.py", ["--rounds", "1", "--size", "256"]),
    ("bench/bench_blender_material.py", ["--size", "64"]),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--only", help="comma-separated benchmark file names to re-run (the others' rows are kept)")
    args = parser.parse_args()
    text = README.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{README}: no {BEGIN} ... {END} markers")
    only = None if args.only is None else {name.strip() for name in args.only.split(",")}
    old_rows = text.split(BEGIN, 1)[1].split(END, 1)[0].splitlines()
    lines = ["| figure | texbake | reference or target | command |", "| --- | --- | --- | --- |"]
    for script, quick in COMMANDS:
        shown = f"`scripts/run python {script}`"
        if only is not None and Path(script).name not in only:
            lines += [row for row in old_rows if row.startswith("| ") and row.rstrip().endswith(f"{shown} |")]
            continue
        command = [sys.executable, script, "--markdown", *(quick if args.quick else [])]
        print("running", " ".join(command[1:]), file=sys.stderr)
        out = subprocess.run(command, cwd=ROOT, check=True, capture_output=True, text=True).stdout
        lines += [row.rstrip() + f" {shown} |" for row in out.splitlines() if row.startswith("| ")]
    when = datetime.date.today().isoformat()
    table = "\n".join([f"Measured {when} on this {os.cpu_count()}-core machine" + (" (--quick: not figures to quote)" if args.quick else "")
                       + " by `scripts/run python bench/readme.py`:", "", *lines])
    head, rest = text.split(BEGIN, 1)
    README.write_text(head + BEGIN + "\n" + table + "\n" + END + rest.split(END, 1)[1])
    print(table)


if __name__ == "__main__":
    main()
