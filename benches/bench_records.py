"""Time ``eodarm records``: one long record, and a campaign of many records streamed.

Usage: python benches/bench_records.py [--samples 1000000] [--records 50] [--campaign-samples 20000]

1. **One record** of ``--samples`` samples × 8 channels (7 steady states with transients
   between them, AR(1) noise), written as CSV (not timed), then read (``read_record``) and
   analysed (``analyse_record``): the time of each, best of 3. Target (issue 22): 10⁶ samples
   × 8 channels in under 2 s.
2. **A campaign** of ``--records`` records of ``--campaign-samples`` samples each, run through
   ``analyse_campaign`` (one record in memory at a time): total time and the peak of the
   Python heap (tracemalloc) against one record's size.

A small run for a quick check: ``--samples 100000 --records 5``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from eodarm.analysis.records import analyse_campaign, analyse_record
from eodarm.data.records import RecordSpec, read_campaign, read_record, write_campaign, write_record

CHANNELS = [
    "dx_mm",
    "dy_mm",
    "dalpha1_deg",
    "dalpha2_deg",
    "dalpha3_deg",
    "dl1_mm",
    "dl2_mm",
    "dl3_mm",
]
MASSES = (0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0)


def make_record(path: Path, n: int, seed: int) -> None:
    """A record of ``n`` samples at 300 Hz: 7 levels, a 1 s ramp with a bump between them,
    AR(1) noise of correlation time 0.05 s."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 300.0
    level = np.zeros((n, len(CHANNELS)))
    edges = np.linspace(0, n, len(MASSES) + 1).astype(int)
    gain = rng.uniform(0.5, 2.0, len(CHANNELS))
    for k, m in enumerate(MASSES):
        level[edges[k] : edges[k + 1]] = m * gain
        if k:
            w = min(300, (edges[k + 1] - edges[k]) // 5)
            level[edges[k] : edges[k] + w] += 3.0 * gain * np.sin(np.linspace(0, np.pi, w))[:, None]
    phi = np.exp(-1 / 15)
    noise = lfilter([np.sqrt(1 - phi**2)], [1, -phi], rng.standard_normal(level.shape), axis=0)
    write_record(path, t, CHANNELS, level + 0.02 * noise)


def best_of(fn, k: int = 3) -> float:
    out = []
    for _ in range(k):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return min(out)


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--records", type=int, default=50)
    ap.add_argument("--campaign-samples", type=int, default=20_000)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "long.csv"
        make_record(p, a.samples, 0)
        size = os.path.getsize(p) / 1e6
        spec = RecordSpec(p, "c1", (97.5, 25.4, 8.3), MASSES)
        rec = read_record(p, 3)
        res = analyse_record(rec, spec)
        assert res.refused is None, res.refused
        t_read = best_of(lambda: read_record(p, 3))
        t_an = best_of(lambda: analyse_record(rec, spec))
        print(f"one record: {a.samples} samples x {len(CHANNELS)} channels ({size:.0f} MB CSV)")
        total = t_read + t_an
        print(f"  read {t_read:.3f} s, steady states and errors {t_an:.3f} s, total {total:.3f} s")
        specs = []
        for i in range(a.records):
            f = Path(d) / f"r{i}.csv"
            make_record(f, a.campaign_samples, i + 1)
            specs.append(RecordSpec(f, f"c{i + 1}", (97.5, 25.4, 8.3), MASSES))
        cp = Path(d) / "campaign.toml"
        write_campaign(cp, specs)
        camp = read_campaign(cp)
        tracemalloc.start()
        t0 = time.perf_counter()
        results = analyse_campaign(camp)
        dt = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
        one = a.campaign_samples * (len(CHANNELS) + 1) * 8 / 1e6
        rows = sum(len(r.rows) for r in results)
        print(f"campaign: {a.records} records x {a.campaign_samples} samples -> {rows} rows")
        print(
            f"  {dt:.2f} s ({dt / a.records * 1e3:.0f} ms per record); peak heap {peak:.1f} MB "
            f"(one record's samples: {one:.1f} MB)"
        )


if __name__ == "__main__":
    main()
