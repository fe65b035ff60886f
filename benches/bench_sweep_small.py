"""Why small sweeps cost more per pose: the core alone, back to back against isolated calls.

Times ``core_reduced`` of ``bench_sweep.py`` (``eodarm._core.sweep`` walking the example arm's
angle grid, ``max`` over (α3, mass), into preallocated outputs, no Dataset) at 1e4, 1e5 and
1e6 poses in two ways:

* **back to back**: k calls in a loop (best of 5 loops), so rayon's worker thread is awake
  when each call starts;
* **isolated**: one call after 20 ms of sleep (best of 20), so the worker thread has gone to
  sleep and must be woken, as for a user's single call.

Run from the repository root, with the package installed::

    python3 benches/bench_sweep_small.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import eodarm
from bench_sweep import ARM_FILE, core_reduced, grid


def main() -> int:
    arm = eodarm.Arm.from_toml(ARM_FILE)
    print("| poses | back to back (ns per pose) | isolated (ns per pose) |")
    print("|---:|---:|---:|")
    for size in (10_000, 100_000, 1_000_000):
        g = grid(size)
        for _ in range(5):
            core_reduced(arm, g)
        k = max(3, 2_000_000 // size)
        loop = float("inf")
        for _ in range(5):
            t0 = time.perf_counter()
            for _ in range(k):
                core_reduced(arm, g)
            loop = min(loop, (time.perf_counter() - t0) / k)
        alone = float("inf")
        for _ in range(20):
            time.sleep(0.02)
            t0 = time.perf_counter()
            core_reduced(arm, g)
            alone = min(alone, time.perf_counter() - t0)
        print(f"| {size:,} | {1e9 * loop / size:.1f} | {1e9 * alone / size:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
