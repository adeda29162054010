"""Re-measure the README's benchmark table: run every benchmark and rewrite the table.

    scripts/run python bench/readme.py [--quick]

Runs each command below with ``--markdown``, gathers the rows it prints and writes them,
each with the command that produced it, between the ``<!-- bench:begin -->`` and
``<!-- bench:end -->`` markers of README.md. ``--quick`` uses fewer runs and smaller
workloads (for a check that the table can be made, not for figures to quote).
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
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    text = README.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{README}: no {BEGIN} ... {END} markers")
    lines = ["| figure | texbake | reference or target | command |", "| --- | --- | --- | --- |"]
    for script, quick in COMMANDS:
        command = [sys.executable, script, "--markdown", *(quick if args.quick else [])]
        print("running", " ".join(command[1:]), file=sys.stderr)
        out = subprocess.run(command, cwd=ROOT, check=True, capture_output=True, text=True).stdout
        shown = f"`scripts/run python {script}`"
        lines += [row.rstrip() + f" {shown} |" for row in out.splitlines() if row.startswith("| ")]
    when = datetime.date.today().isoformat()
    table = "\n".join([f"Measured {when} on this {os.cpu_count()}-core machine" + (" (--quick: not figures to quote)" if args.quick else "")
                       + " by `scripts/run python bench/readme.py`:", "", *lines])
    head, rest = text.split(BEGIN, 1)
    README.write_text(head + BEGIN + "\n" + table + "\n" + END + rest.split(END, 1)[1])
    print(table)


if __name__ == "__main__":
    main()
