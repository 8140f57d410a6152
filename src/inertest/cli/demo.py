"""``inertest demo``: the example campaign end to end."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click


@click.command()
@click.option("--examples", "examples_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Folder with demo.toml (default: ./examples).")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("inertest-report"), show_default=True,
              help="Where to write the HTML report.")
def demo(examples_dir: Path | None, report_dir: Path) -> None:
    """Simulate the example campaign (examples/demo.toml), fit each test, print and report."""
    # the campaign loads procedures, budgets (scipy.stats) and reports: only when it runs
    from inertest.cli._common import command_line, print_identity
    from inertest.cli._verdicts import verdict_summary
    from inertest.cli.procedure import print_result
    from inertest.demo import (
        find_examples,
        run_acceptance,
        run_campaign,
        run_noise,
        run_thermal,
        write_campaign_report,
    )

    folder = examples_dir if examples_dir is not None else find_examples()

    def started(what: str) -> Callable[[int, int, str], None]:
        def line(k: int, n: int, title: str) -> None:  # one line per test, as it starts
            click.echo(f"[{what} {k}/{n}] {title} ...", err=True)
        return line

    tests = run_campaign(folder / "demo.toml", progress=started("test"))
    for t in tests:
        click.echo(f"\n{t.title} ({t.plan_path}; noise {t.noise:g} per reading, seed {t.seed})")
        print_identity(t.to_dict())
        print_result(t.result, truth=t.truth_deg_h)
        spec = "" if t.conformance is None else f" ({t.conformance.spec_name})"
        click.echo(f"verdict{spec}: "
                   f"{verdict_summary(None if t.conformance is None else t.conformance.to_dict())}")
    noise = run_noise(folder / "demo.toml", progress=started("noise"))
    for n in noise:
        from inertest.cli._common import print_table
        from inertest.report.imu_noise import summary_rows

        click.echo(f"\n{n.title} ({n.data_path}; real recording)")
        h, r = summary_rows(n.result)
        print_table("noise per channel: Kalibr noise density N and random walk K (< : upper "
                    "bound), IEEE 952 bias instability B", h, r)
    thermal = run_thermal(folder / "demo.toml", progress=started("thermal"))
    for th in thermal:
        click.echo(f"\n{th.title} ({th.plan_path}; noise {th.noise:g} per reading, seed "
                   f"{th.seed}): {len(th.result.step_temperature_c)} steps; held-out run, "
                   "RMS error / drift before -> after [mg]:")
        for axis in "xyz":
            (rb, db), (ra, da) = th.before_mg[axis], th.after_mg[axis]
            click.echo(f"  output_{axis}: {rb:.3f} / {db:.3f} -> {ra:.3f} / {da:.3f}")
        flagged = [name for name, h in th.result.hysteresis.items() if h.significant]
        click.echo("  hysteresis heating vs cooling: "
                   + (", ".join(flagged) if flagged else "none significant"))
    acceptance = run_acceptance(folder / "demo.toml")
    for a in acceptance:
        from inertest.cli._common import print_table
        from inertest.report.acceptance import CLAUSE_HEADER, clause_rows

        click.echo(f"\n{a.title} ({a.manifest})")
        print_table(f"clauses of {a.outcome.campaign.spec.name}", CLAUSE_HEADER,
                    clause_rows(a.outcome.to_dict()))
        click.echo(f"overall verdict: {a.outcome.overall}")
        if a.lot is not None:
            from inertest.report.lot import SUMMARY_HEADER
            from inertest.report.lot import summary_rows as lot_rows

            print_table(f"lot of {len(a.lot.serials)} simulated units", SUMMARY_HEADER,
                        lot_rows(a.lot))
    index = write_campaign_report(tests, report_dir, noise=noise, thermal=thermal,
                                  acceptance=acceptance, command=command_line())
    click.echo(f"\nreport: {index}")
