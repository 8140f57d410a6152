"""Start-up imports of the command line (issue 18): what each command's --help and a
``fit --no-store`` load. Import-level checks only; the times are in benchmarks/bench_startup.py.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.special
import scipy.stats

from inertest.cli import _COMMANDS
from inertest.estimation import model_checks

#: Modules that cost 0.1-1.5 s to import and belong to the commands that use them.
HEAVY = ("matplotlib", "sqlalchemy", "alembic", "pandas", "scipy.stats", "scipy.optimize",
         "rich", "numba", "sklearn", "inertest.store")
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gyro_rate_table"


def _loaded_after(code: str) -> list[str]:
    probe = (f"import sys, contextlib, io\n{code}\n"
             f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.strip().splitlines()
    return [m for m in (out[-1] if out else "").split(",") if m]


@pytest.mark.parametrize("command", ["", *_COMMANDS])
def test_help_of_every_command_loads_no_heavy_module(command):
    argv = [command, "--help"] if command else ["--help"]
    code = ("from inertest.cli import main\n"
            f"with contextlib.redirect_stdout(io.StringIO()): main({argv!r})")
    assert _loaded_after(code) == []


@pytest.mark.parametrize("command", ["fit", "simulate", "batch", "plan-check"])
def test_help_of_the_fit_commands_leaves_the_fit_machinery_unloaded(command):
    # `fit --help` loaded the runner, the API and the report tables (2.2x `import numpy`);
    # the commands import them when they run.
    code = ("from inertest.cli import main\n"
            f"with contextlib.redirect_stdout(io.StringIO()): main([{command!r}, '--help'])\n"
            "print(','.join(m for m in ('inertest.app.run', 'inertest.api', "
            "'inertest.report.identification') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", "import sys, contextlib, io\n" + code],
                         capture_output=True, text=True, check=True).stdout.strip()
    loaded = out.splitlines()[-1] if out else ""
    assert loaded == ""


def test_fit_no_store_loads_neither_the_database_nor_scipy_stats(tmp_path):
    data = tmp_path / "data.csv"
    code = ("from inertest.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    assert main(['simulate', {str(EXAMPLE / 'plan.toml')!r}, '--truth', "
            f"{str(EXAMPLE / 'truth.toml')!r}, '-o', {str(data)!r}]) == 0\n"
            "for m in [m for m in sys.modules if m.startswith('inertest.store')]:\n"
            "    del sys.modules[m]\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    assert main(['fit', {str(EXAMPLE / 'plan.toml')!r}, {str(data)!r}, "
            "'--no-store', '--json']) == 0")
    loaded = _loaded_after(code)
    for name in ("sqlalchemy", "alembic", "inertest.store", "scipy.stats", "matplotlib",
                 "numba"):
        assert name not in loaded


def test_fit_no_store_of_a_polar_tumble_csv_loads_neither_pandas_nor_scipy_optimize(tmp_path):
    # Issue 18: the CSV's columns come from the Arrow buffers (Arrow's to_numpy imports
    # pandas) and the REML line search is identify's own (no scipy.optimize).
    example = EXAMPLE.parent / "polar_tumble"
    data = tmp_path / "data.csv"
    code = ("from inertest.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    assert main(['simulate', {str(example / 'plan.toml')!r}, '--truth', "
            f"{str(example / 'truth.toml')!r}, '-o', {str(data)!r}, '--noise', '0.01']) == 0\n"
            "for m in [m for m in sys.modules if m.startswith(('pandas', 'scipy.optimize'))]:\n"
            "    del sys.modules[m]\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    assert main(['fit', {str(example / 'plan.toml')!r}, {str(data)!r}, "
            "'--no-store', '--json']) == 0")
    loaded = _loaded_after(code)
    for name in ("pandas", "scipy.optimize", "scipy.stats", "inertest.store"):
        assert name not in loaded


def test_tail_probabilities_from_scipy_special_equal_scipy_stats():
    """identify's chi-square, F and normal tails without scipy.stats: the same numbers."""
    rng = np.random.default_rng(18)
    for _ in range(500):
        dof, dof2 = int(rng.integers(1, 400)), int(rng.integers(1, 20000))
        x, f = float(rng.exponential(dof)), float(rng.exponential(1.0))
        q = float(10 ** rng.uniform(-14, -1))
        assert model_checks.chi2_sf(x, dof) == float(scipy.stats.chi2.sf(x, dof))
        # and the regularised upper incomplete gamma Q(dof/2, x/2) of the textbook
        np.testing.assert_allclose(model_checks.chi2_sf(x, dof),
                                   scipy.special.gammaincc(dof / 2, x / 2), rtol=1e-12,
                                   atol=1e-300)
        assert float(scipy.special.fdtrc(dof, dof2, f)) == float(scipy.stats.f.sf(f, dof, dof2))
        assert -float(scipy.special.ndtri(q)) == float(scipy.stats.norm.isf(q))


def test_thermal_quantity_choices_are_the_procedures():
    # the CLI names them so that `thermal --help` need not import the procedure
    from inertest.cli.thermal import QUANTITY_NAMES
    from inertest.procedures.thermal_compensation import QUANTITIES

    assert list(QUANTITY_NAMES) == list(QUANTITIES)
