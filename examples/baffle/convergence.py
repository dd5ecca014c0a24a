"""Convergence of the recovered-temperature error with the number of super nodes (thesis Fig. 6.10).

Runs the baffle example (``case.toml``) at several n_SN in three solar modes and prints, for each run, the RMS /
max error of the recovered temperatures against the detailed reference **with the reference's own noise beside
it** (``summary.json`` ``accuracy.reference_noise_rms_K``: two independent half-budget references), then the
log-log slope of RMS against n_SN fitted **only on the points above 3x the reference noise**
(:func:`benchmarks.accuracy.slope_above_noise`, the one implementation of that rule).  An error below about 3x
the noise says "as good as the reference", not how fast the reduction converges.

Modes:

* ``detailed``: ``solar_on = "detailed"`` (the case file's setting): the Sun traced on the FE faces, passed through
  the exact power distribution; the reduced model and the reference share that solar map, so the error cannot
  see solar ray noise or shadow resolution;
* ``super_faces``: the thesis' super-face solar loads, clusters following a coarse solar pre-pass
  (``[clustering] solar_aware``, the default in that mode);
* ``thesis``: super-face solar loads with the solar-aware clustering off: the thesis' scheme, the only mode to
  compare with its Fig. 6.9-6.10 (1.4 / 3.0 K at 10, 0.21 / 0.77 K at 100 super nodes; "almost linear").

The detailed reference is the same at every n_SN of a mode, so its tracings are computed once and then reused
from a stage cache in a temporary folder.

Run from the repository root::

    python examples/baffle/convergence.py                               # 3 modes x n_SN 10, 20, 50, 100, 200
    python examples/baffle/convergence.py --modes thesis --n 10 100     # a reduced sweep
    python examples/baffle/convergence.py --modes detailed --n 100 200 --seed 1   # another ray seed
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # the repository root, for benchmarks.accuracy

from benchmarks.accuracy import slope_above_noise  # noqa: E402
from fem2tmm import Case, run  # noqa: E402

N_SN = (10, 20, 50, 100, 200)
#: mode -> (solar_on, [clustering] solar_aware: None = the default of that solar mode)
MODES = {"detailed": ("detailed", None), "super_faces": ("super_faces", None), "thesis": ("super_faces", False)}


def mode_case(base: Case, mode: str, n: int, seed: int | None = None) -> Case:
    """``base`` with every part at ``n`` super nodes in solar ``mode`` (a key of :data:`MODES`), and
    ``[radiation] seed`` replaced by ``seed`` if given."""
    solar_on, aware = MODES[mode]
    radiation = base.radiation if seed is None else dataclasses.replace(base.radiation, seed=seed)
    return dataclasses.replace(
        base,
        radiation=radiation,
        parts=tuple(dataclasses.replace(p, super_nodes=n) for p in base.parts),
        environment=dataclasses.replace(base.environment, solar_on=solar_on),
        clustering=dataclasses.replace(base.clustering, solar_aware=aware),
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=list(N_SN), help="super-node counts (default: %(default)s)")
    ap.add_argument("--modes", nargs="+", choices=list(MODES), default=list(MODES), help="solar modes (default: all)")
    ap.add_argument("--seed", type=int, default=None, help="[radiation] seed (default: the case file's)")
    args = ap.parse_args(argv)
    base = Case.from_toml(HERE / "case.toml")
    t_all = time.perf_counter()
    rows = {m: [] for m in args.modes}
    with tempfile.TemporaryDirectory(prefix="fem2tmm-convergence-") as cache:
        for mode in args.modes:
            for n in args.n:
                t0 = time.perf_counter()
                s = run(mode_case(base, mode, n, args.seed), cache=cache).summary
                acc = s["accuracy"]
                noise = acc.get("reference_noise_rms_K") or 0.0
                rows[mode].append((s["reduced"]["super_nodes"], acc["rms_K"], acc["max_K"], noise))
                print(f"{mode:12s} n_SN = {rows[mode][-1][0]:4d}   RMS {acc['rms_K']:.4f} K   max {acc['max_K']:.4f} K"
                      f"   reference noise RMS {noise:.5f} K   (RMS / noise {acc['rms_K'] / max(noise, 1e-300):.0f})"
                      f"   radiation share {acc.get('radiation_share', float('nan')):.3f}"
                      f"   ({time.perf_counter() - t0:.1f} s)", flush=True)
    print()
    for mode, pts in rows.items():
        n, rms, _, noise = (list(c) for c in zip(*pts))
        floor = max(noise)
        used = [k for k, r in zip(n, rms) if r > 3 * floor]
        slope = slope_above_noise(n, rms, floor)
        fit = "too few points above it to fit" if slope is None else f"RMS ~ n_SN^-{slope:.2f} over n_SN = {used}"
        print(f"{mode}: reference noise (largest of the runs) {floor:.5f} K, 3x = {3 * floor:.5f} K; {fit}")
    print("thesis Fig. 6.10 (like for like only with mode 'thesis'): about n_SN^-1")
    print(f"total {time.perf_counter() - t_all:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
