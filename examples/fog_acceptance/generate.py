"""Write the simulated data of the FOG acceptance campaign (and, with --units, of a whole lot).

Every file is made by inertest's own virtual instruments (each procedure's ``simulate``, the same
code as ``inertest simulate``) from the ``truth.toml`` beside each plan, with the noise per
reading that campaign.toml states and a fixed seed per test, so the files are reproducible:

    python examples/fog_acceptance/generate.py              # the shipped files, unit FOG-Z-0231
    python examples/fog_acceptance/generate.py --units 12 --out lot   # a lot of 12 units

A lot: each unit gets its own serial (FOG-Z-1001, ...), its own coefficients drawn around the
shipped unit's (:func:`inertest.demo.lot_truths`: unit-to-unit spread, unit 7 with a high bias
to stand out), its own seeds, and a
folder with copies of the plans (serial replaced), its data and its campaign.toml. The data are
simulated, not measured: they show the workflow, not a real gyro (licence: LICENSE beside this
file).
"""

from __future__ import annotations

import argparse
import re
import shutil
import tomllib
from pathlib import Path

import numpy as np

import inertest
from inertest.demo import lot_truths
from inertest.io.data_file import write_table
from inertest.io.plan_file import load_truth

HERE = Path(__file__).resolve().parent
def write_unit(manifest: Path, out: Path, truths: dict[str, dict[str, float]],
               seed: int) -> None:
    """Simulate every test of ``manifest`` with ``truths`` and write the files it lists."""
    doc = tomllib.loads(manifest.read_text(encoding="utf-8"))
    for k, t in enumerate(doc["test"]):
        plan_path = manifest.parent / t["plan"]
        plan = inertest.load_plan(plan_path)
        data = inertest.simulate(plan, truths[t["name"]], noise=float(t.get("noise", 0.0)),
                                 rng=seed + k)
        if "data" in t:
            write_table(out / t["data"], data)
            continue
        labels = list(dict.fromkeys(str(x) for x in data["run"]))
        for label, r in zip(labels, t["runs"], strict=True):
            rows = np.asarray(data["run"]).astype(str) == label
            path = r["data"] if isinstance(r, dict) else r
            write_table(out / path, {c: np.asarray(v)[rows] for c, v in data.items()
                                     if c != "run"})


def truths_of(manifest: Path) -> dict[str, dict[str, float]]:
    """The truth of each test: ``truth.toml`` beside its plan."""
    doc = tomllib.loads(manifest.read_text(encoding="utf-8"))
    return {t["name"]: load_truth((manifest.parent / t["plan"]).parent / "truth.toml")
            for t in doc["test"]}


def write_lot(units: int, out: Path, seed: int = 100) -> None:
    """A lot of ``units`` units, each in its own folder with its campaign."""
    lots = lot_truths(truths_of(HERE / "campaign.toml"), units, seed)
    for u in range(units):
        serial = f"FOG-Z-{1001 + u}"
        folder = out / serial
        for sub in ("turn_on", "warm_up", "in_run", "rate_table", "thermal"):
            (folder / sub).mkdir(parents=True, exist_ok=True)
            for f in ("plan.toml", "truth.toml"):
                text = (HERE / sub / f).read_text(encoding="utf-8")
                (folder / sub / f).write_text(text.replace("FOG-Z-0231", serial),
                                              encoding="utf-8")
        truths = lots[u]
        text = (HERE / "campaign.toml").read_text(encoding="utf-8")
        text = text.replace("FOG-Z-0231", serial).replace("ATP-2026-0231", f"ATP-2026-{u + 1:04d}")
        text = re.sub(r'"\.\./(specs|lab)/', lambda m: f'"{(HERE.parent / m.group(1)).as_posix()}/',
                      text)
        (folder / "campaign.toml").write_text(text, encoding="utf-8")
        write_unit(folder / "campaign.toml", folder, truths, seed=1000 * (u + 1))


def main() -> None:
    """The command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units", type=int, default=0, help="write a lot of this many units")
    ap.add_argument("--out", type=Path, default=None, help="folder of the lot")
    a = ap.parse_args()
    if a.units:
        if a.out is None:
            ap.error("--units needs --out FOLDER")
        if a.out.exists():
            shutil.rmtree(a.out)
        write_lot(a.units, a.out)
    else:
        write_unit(HERE / "campaign.toml", HERE, truths_of(HERE / "campaign.toml"), seed=2026)


if __name__ == "__main__":
    main()
