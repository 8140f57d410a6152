"""Every procedure's model checks keep their stated false-alarm rate, and still see a misfit.

Issue 28: a check is only useful if its false-alarm rate is the one it states. Each procedure
states ``alpha`` per test (:data:`inertest.estimation.model_checks.CHECK_ALPHA`) for its four
tests (variance, Ljung-Box, Bonferroni outliers, mean shift), so at most ``4 alpha`` of records
whose model is true may be flagged. Here each procedure's example is simulated many times with
the model true (its stated noise per reading) and the flags are counted against the binomial
bound of that rate; then one position of the same records is shifted (a step the model does not
have: a knocked fixture, a mislabelled mounting) and nearly every record must be flagged.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.stats

import inertest
from inertest.errors import InertestWarning
from inertest.estimation.model_checks import CHECK_ALPHA
from inertest.io.plan_file import load_truth
from inertest.procedures import procedure
from procedure_examples import EXAMPLES

pytestmark = pytest.mark.slow

#: Kinds whose checks are statistical tests at ``alpha`` (orientation-free checks tolerances).
#: Value: records simulated (the centrifuge's take 0.6 s each). At the 13 % flag rate the issue
#: found in the Allan check, 50 records flag 6.5 on average against a bound of 2 or 3.
RECORDS = {
    "polar-tumble": 50, "local-level-tumble": 50, "gyro-rate-table": 50,
    "gyro-triad-rotation": 50, "ferraris": 40, "triad-multiposition": 50,
    "accelerometer-multipoint": 50, "servo-table": 40, "centrifuge-nine-position": 8,
}
#: Kind -> (columns naming a position, output column) for the shifted position.
STEP = {
    "polar-tumble": (("mounting", "angle_deg"), "output"),
    "local-level-tumble": (("I_dir", "O_dir", "S_dir"), "output"),
    "gyro-rate-table": (("rate_deg_s",), "output"),
    "accelerometer-multipoint": (("mounting", "angle_deg"), "output"),
    "triad-multiposition": (("position",), "output_y"),
}
#: The step, in standard errors of a position mean. Few positions leave few residual degrees
#: of freedom (12 positions, 8 dof on the triad) and the noise level is fitted to the same
#: residuals, so a single step is seen with certainty only when it stands well out: 40 standard
#: errors is 1.3 mg on the triad's example (0.1 mg per reading, 10 readings per position).
STEP_SE = 40.0


def _flagged(proc, plan, data) -> bool:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertestWarning)  # counted from the verdicts below
        res = proc.fit(plan, data)
    checks = res.to_dict().get("checks") or []
    checks = checks if isinstance(checks, list) else [checks]
    assert checks, "a procedure without model checks"
    return any(c["verdict"] != "consistent" for c in checks)


def _example(kind, examples_dir):
    folder, truth, noise = EXAMPLES[kind]
    plan = inertest.load_plan(examples_dir / folder / "plan.toml")
    return procedure(kind), plan, load_truth(examples_dir / folder / truth), noise


@pytest.mark.parametrize("kind", sorted(RECORDS))
def test_clean_records_are_flagged_at_most_at_the_stated_rate(kind, examples_dir):
    proc, plan, truth, noise = _example(kind, examples_dir)
    n = RECORDS[kind]
    flags = sum(_flagged(proc, plan, proc.simulate(plan, truth, noise=noise, rng=5000 + s))
                for s in range(n))
    stated = 4 * CHECK_ALPHA  # four tests, each at alpha
    # Fails by chance with probability below 1e-3 when the rate is the stated one.
    bound = int(scipy.stats.binom.ppf(0.999, n, stated))
    assert flags <= bound, f"{kind}: {flags} of {n} clean records flagged (stated {stated:.1%})"


@pytest.mark.parametrize("kind", sorted(STEP))
def test_a_position_shifted_by_a_step_is_flagged(kind, examples_dir):
    proc, plan, truth, noise = _example(kind, examples_dir)
    columns, out = STEP[kind]
    flags, n = 0, 20
    for s in range(n):
        data = {k: np.asarray(v).copy() for k, v in
                proc.simulate(plan, truth, noise=noise, rng=7000 + s).items()}
        position = np.rec.fromarrays([data[c] for c in columns])
        positions = np.unique(position)
        one = position == positions[len(positions) // 3]
        data[out][one] += STEP_SE * noise / np.sqrt(one.sum())
        flags += _flagged(proc, plan, data)
    assert flags >= 0.9 * n, f"{kind}: a step flagged in only {flags} of {n} records"
