"""Result rows shared by the benchmarks: ``(figure, texbake, reference or target)``.

Each benchmark prints its own side-by-side table; with ``--markdown`` it prints only its
rows as markdown table lines, which ``bench/readme.py`` gathers into the README.
"""

from __future__ import annotations


def emit(rows: list[tuple[str, str, str]], markdown: bool) -> None:
    if markdown:
        for row in rows:
            print("| " + " | ".join(str(c).replace("|", "/") for c in row) + " |")
        return
    width = max(len(r[0]) for r in rows)
    print(f"{'figure':<{width}}  {'texbake':>12}  reference / target")
    for figure, ours, other in rows:
        print(f"{figure:<{width}}  {ours:>12}  {other}")
