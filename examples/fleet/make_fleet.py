r"""A production lot of simulated MEMS accelerometer triads, as one batch (issue 31).

Each unit has its own errors, drawn from a production spread (scale factor 0.15 %, axis
misalignment 600 urad, bias 8 mg; one unit in fifty with a bias of 45-60 mg, the tail a line
finds), and its own twelve-position test of the triad-multiposition example (120 readings,
0.01 m/s^2 of noise per reading at 1670.7 count/(m/s^2)). The script writes, under FOLDER:
one plan per unit (its serial), one data file per unit, the units' true coefficients
(``truth.csv``, to check the lot statistics against), and ``batch.toml`` with the production
spec as default, then prints the commands that run the lot:

    python examples/fleet/make_fleet.py /tmp/fleet --units 1000
    inertest batch /tmp/fleet/batch.toml --workers 16 --db /tmp/fleet/history.db --quiet
    inertest lot --db /tmp/fleet/history.db --procedure triad-multiposition \
        --spec examples/fleet/spec.toml --report /tmp/fleet/lot.html

Everything is simulated from a seed: the same command writes the same files.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

import inertest
from inertest.io.data_file import write_table

HERE = Path(__file__).resolve().parent
TEMPLATE = HERE.parent / "triad_multiposition" / "plan.toml"
NOMINAL_K = 1670.7  # count/(m/s^2) = 16384 count/g
NAMES = ("K_x", "K_y", "K_z", "M_xy", "M_xz", "M_yx", "M_yz", "M_zx", "M_zy",
         "B_x", "B_y", "B_z")


def unit_truth(rng: np.random.Generator) -> dict[str, float]:
    """One unit's errors: K [count/(m/s^2)], M [urad], B [mg]."""
    truth = {f"K_{a}": NOMINAL_K * (1 + 0.0015 * rng.standard_normal()) for a in "xyz"}
    truth |= {n: 600.0 * rng.standard_normal() for n in NAMES[3:9]}
    truth |= {f"B_{a}": 8.0 * rng.standard_normal() for a in "xyz"}
    if rng.random() < 0.02:  # the tail: a bias far out on one axis
        truth[f"B_{rng.choice(list('xyz'))}"] = rng.choice([-1, 1]) * rng.uniform(45, 60)
    return truth


def make_fleet(folder: Path, units: int, *, seed: int = 2026, noise: float = 16.7) -> Path:
    """Write the lot under ``folder``; returns the batch manifest. ``noise`` [count]."""
    folder.mkdir(parents=True, exist_ok=True)
    template = TEMPLATE.read_text(encoding="utf-8")
    assert 'serial = "ACC3-0112"' in template
    rngs = np.random.SeedSequence(seed).spawn(units)
    runs, rows = [], []
    for k, ss in enumerate(rngs):
        rng = np.random.default_rng(ss)
        serial = f"MEMS-{k:04d}"
        truth = unit_truth(rng)
        plan = folder / f"{serial}.toml"
        plan.write_text(template.replace('serial = "ACC3-0112"', f'serial = "{serial}"'),
                        encoding="utf-8")
        data = folder / f"{serial}.csv"
        write_table(data, inertest.simulate(plan, truth, noise=noise, rng=rng))
        runs.append(f'[[run]]\nplan = "{plan.name}"\ndata = "{data.name}"\n')
        rows.append({"serial": serial, **truth})
    with (folder / "truth.csv").open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=["serial", *NAMES])
        w.writeheader()
        w.writerows(rows)
    manifest = folder / "batch.toml"
    manifest.write_text(f'[defaults]\nspec = "{HERE / "spec.toml"}"\n\n' + "\n".join(runs),
                        encoding="utf-8")
    return manifest


def main() -> None:
    """Write the lot under FOLDER."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--units", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args()
    manifest = make_fleet(args.folder, args.units, seed=args.seed)
    print(f"{args.units} units in {args.folder}; run them with:")
    print(f"  inertest batch {manifest} --workers 16 --db {args.folder / 'history.db'} --quiet")
    print(f"  inertest lot --db {args.folder / 'history.db'} --procedure triad-multiposition "
          f"--spec {HERE / 'spec.toml'} --report {args.folder / 'lot.html'}")


if __name__ == "__main__":
    main()
