"""Convergence of the recovered-temperature error with the number of super nodes (thesis Fig. 6.10).

Runs the baffle example at n_SN in {10, 20, 50, 100, 200} with the thesis' super-face solar loads and with
fluxes traced on the detailed mesh (exact power distribution), and prints the RMS / max error against the
detailed reference and the log-log slope (the thesis finds the RMS error falling roughly as 1/n_SN).

Run from the repository root:  python examples/baffle/convergence.py   (≈ 2–3 minutes on 2 cores)
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from fem2tmm import Case, run

HERE = Path(__file__).resolve().parent
N_SN = (10, 20, 50, 100, 200)


def main() -> int:
    base = Case.from_toml(HERE / "case.toml")
    rows = []
    for mode in ("super_faces", "detailed"):
        for n in N_SN:
            case = dataclasses.replace(
                base,
                parts=tuple(dataclasses.replace(p, super_nodes=n) for p in base.parts),
                environment=dataclasses.replace(base.environment, solar_on=mode),
            )
            t0 = time.perf_counter()
            acc = run(case).summary["accuracy"]
            rows.append((mode, n, acc["rms_K"], acc["max_K"], time.perf_counter() - t0))
            print(f"{mode:12s} n_SN = {n:4d}   RMS {acc['rms_K']:.4f} K   max {acc['max_K']:.4f} K   "
                  f"({rows[-1][-1]:.1f} s)", flush=True)
    for mode in ("super_faces", "detailed"):
        n = np.array([r[1] for r in rows if r[0] == mode], float)
        rms = np.array([r[2] for r in rows if r[0] == mode])
        slope = np.polyfit(np.log(n), np.log(rms), 1)[0]
        print(f"{mode}: RMS error ~ n_SN^{slope:.2f} (thesis Fig. 6.10: about n_SN^-1)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
