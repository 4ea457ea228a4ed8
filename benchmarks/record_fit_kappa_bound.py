"""Benchmark: the record fit's sampler against the lower bound of kappa.

With a fixed reference lidar the pair term explains the floating lidar's scatter and the
record model's ``kappa`` (its own noise beyond it) goes to 0: the log-kappa posterior is the
half-normal prior's ``exp(log kappa)`` tail, cut above where the records resolve ``kappa``.
The more records, the lower that cut. ``Priors.kappa_min`` bounds ``log kappa`` from below;
at 1e-4 (the shipped bound is 1e-8) a year of records puts the posterior's peak next to
it, and the sampler slows down (DE proposals across the wall are rejected, the Student-t
independence proposal fits the truncated shape worse).

The run: the records of a pipeline run's ``results/bins/assignments.csv`` (e.g. the 1-year
scaling run's), the pair term as the pipeline computes it for the default scenario's
reference lidar, one fit per ``kappa_min`` with the shipped sampler settings, stopped at the
first budget (``max_step_factor`` 1, so every fit costs the same). Per bound: the
independence move's expected acceptance after burn-in, the largest autocorrelation time
per parameter, the chain length the adaptive extension would ask for
(``1.1 x 50 tau``), the CPU time of the first budget, and the posterior of ``kappa``.
Writes ``benchmarks/results/record_fit_kappa_bound.csv`` and ``.png``.

Usage: ``python benchmarks/record_fit_kappa_bound.py --assignments <run>/results/bins/assignments.csv``
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import yaml  # noqa: E402

from flidar_uq.campaign.scenarios import reference_sampling  # noqa: E402
from flidar_uq.correction.reference import Reference  # noqa: E402
from flidar_uq.inference import Priors, SamplerSettings, record_fit, sampler  # noqa: E402
from flidar_uq.physics.surrogate import get_surrogate  # noqa: E402
from flidar_uq.seeding import child_seed  # noqa: E402
from flidar_uq.workflow.files import read_csv  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "record_fit_kappa_bound"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assignments", type=Path, required=True)
    ap.add_argument("--bounds", default="1e-4,1e-8", help="comma list of kappa_min values")
    args = ap.parse_args()
    cfg = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    virtual = reference_sampling("default")
    ref = Reference.from_config(
        cfg["reference"], lidar="zephir300", virtual_kind=virtual["reference_kind"]
    )
    records = read_csv(args.assignments)
    pair = ref.noise(
        records,
        heights_in_turn=virtual["heights_in_turn"],
        refocus_delay_s=virtual["refocus_delay_s"],
        point_sample_interval_s=1.0,
        turbulence_dt_s=virtual["turbulence_dt_s"],
        seed=cfg["inference"]["seed"],
    ).pair_log_sd
    fields = SamplerSettings.__dataclass_fields__
    settings = SamplerSettings(
        **{k: v for k, v in cfg["inference"].items() if k in fields},
        max_step_factor=1.0,
        global_max_step_factor=1.0,
    )
    seen = {}
    acceptance = sampler._independence_acceptance

    def record_acceptance(*a, **k):  # the fit's own call, recorded
        seen["acceptance"] = acceptance(*a, **k)
        return seen["acceptance"]

    sampler._independence_acceptance = record_acceptance
    gs = settings.for_global_fit()
    rows = []
    for bound in (float(b) for b in args.bounds.split(",")):
        seen.clear()
        t0 = time.process_time()
        fit = record_fit.fit_record_model(
            records,
            surrogate=get_surrogate("zephir300"),
            settings=settings,
            seed=child_seed(cfg["inference"]["seed"], 0),
            priors=Priors(**cfg["priors"], kappa_min=bound),
            pair_log_sd=pair,
        )
        cpu = time.process_time() - t0
        kappa = fit.flat("kappa")
        # the length the adaptive extension would ask for from here (capped off in this run)
        target = sampler._extension_target(gs.nsteps, fit.diagnostics, fit.failure_reasons, gs)
        row = {
            "kappa_min": bound,
            "n_records": fit.info["n_records"],
            "nsteps": settings.nsteps,
            "independence_acceptance": seen.get("acceptance", np.nan),
            **{f"tau_{n}": d["tau"] for n, d in fit.diagnostics.items()},
            "tau_max": max(d["tau"] for d in fit.diagnostics.values()),
            "extension_target_steps": max(target, gs.nsteps),
            "converged_at_first_budget": fit.converged,
            "cpu_s_first_budget": cpu,
            "kappa_q05": np.quantile(kappa, 0.05),
            "kappa_median": np.median(kappa),
            "kappa_q95": np.quantile(kappa, 0.95),
            "log_kappa_at_bound_share": float(np.mean(np.log(kappa) < np.log(bound) + 0.5)),
        }
        rows.append(row)
        print({k: (float(f"{v:.6g}") if isinstance(v, float) else v) for k, v in row.items()})
    table = pd.DataFrame(rows)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT.with_suffix(".csv"), index=False, float_format="%.6g")
    a, b = table.iloc[0], table.iloc[-1]
    print(
        f"kappa_min {a.kappa_min:g} vs {b.kappa_min:g}: largest autocorrelation time "
        f"{a.tau_max:.1f} vs {b.tau_max:.1f} steps ({a.tau_max / b.tau_max:.1f}x); the "
        f"extension would run {a.extension_target_steps:.0f} vs "
        f"{b.extension_target_steps:.0f} steps"
    )
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    names = [c[4:] for c in table.columns if c.startswith("tau_") and c != "tau_max"]
    x = np.arange(len(names))
    for k, (_, r) in enumerate(table.iterrows()):
        ax[0].bar(
            x + 0.4 * k - 0.2,
            [r[f"tau_{n}"] for n in names],
            0.4,
            label=f"kappa_min {r.kappa_min:g} (acceptance {r.independence_acceptance:.2f})",
        )
    ax[0].axhline(settings.nsteps / (1.1 * settings.n_autocorr), color="k", lw=0.8, ls="--")
    ax[0].set_xticks(x, names, rotation=20)
    ax[0].set_ylabel("autocorrelation time (steps)")
    ax[0].set_title(
        f"record fit, {int(a.n_records):,} records; dashed: passes at {settings.nsteps}"
    )
    ax[0].legend(fontsize=8)
    ax[1].bar(
        [f"{v:g}" for v in table.kappa_min],
        table.cpu_s_first_budget * table.extension_target_steps / gs.nsteps,
    )
    ax[1].set_xlabel("kappa_min")
    ax[1].set_ylabel("projected CPU to convergence (s)")
    ax[1].set_title("first budget x extension / budget")
    fig.tight_layout()
    fig.savefig(OUT.with_suffix(".png"), dpi=110)


if __name__ == "__main__":
    main()
