"""Run every benchmark module, or those named on the command line: a module's exact name
(``bench_sim``) picks that one, any other word every module whose name contains it
(``sim``: bench_sim, bench_sim_coverage …). ``TRIMD_BENCH_TINY=1``: each at a tiny size
(:mod:`bench.size`)."""

from __future__ import annotations

import importlib
import pkgutil
import sys
from pathlib import Path


def main() -> int:
    names = sorted(m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)])
                   if m.name.startswith("bench_"))
    wanted = sys.argv[1:]
    for name in names:
        if wanted and not any(w == name or (w not in names and w in name) for w in wanted):
            continue
        print(f"== {name}", flush=True)
        importlib.import_module(f"bench.{name}").main()
    return 0


if __name__ == "__main__":
    sys.exit(main())
