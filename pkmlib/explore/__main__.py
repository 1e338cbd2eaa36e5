"""``python -m pkmlib.explore --out site/explore/data [--only p1 p5]``: write the interactive figures' data."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import MODULES


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pkmlib.explore", description=__doc__)
    ap.add_argument("--out", default="site/explore/data", help="folder the site serves (default %(default)s)")
    ap.add_argument("--only", nargs="*", choices=sorted(MODULES), help="only these figures' modules")
    a = ap.parse_args(argv)
    out = Path(a.out)
    for name in a.only or MODULES:
        t = time.perf_counter()
        files = MODULES[name].write(out)
        size = sum(f.stat().st_size for f in files)
        print(f"pkmlib.explore {name}: {len(files)} files, {size / 1e6:.2f} MB in {time.perf_counter() - t:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
