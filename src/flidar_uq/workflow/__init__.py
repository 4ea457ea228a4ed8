"""Workflow glue: one function per Snakemake step, report assembly and plots.

The top layer; may import anything in flidar_uq. ``snakemake`` itself is touched
only in the repository's ``workflow/scripts/``.

Modules: :mod:`.inputs` (the config and the user's data checked before any expensive
step, exit statuses, the validation report), :mod:`.files` (CSV read/write, logging),
:mod:`.data_steps` (campaign, validate,
QC, motion statistics, bins, sigma_Z table), :mod:`.imu_step` (motion statistics of a raw IMU
series), :mod:`.inference_steps` (per-bin batches, global models, global fit),
:mod:`.propagation_step` (corrected TI: files in, :func:`flidar_uq.correction.campaign.correct_campaign`, files out), :mod:`.los_step` (the LOS branch and its agreement
with the Bayesian TI), :mod:`.report_step` (HTML report), :mod:`.series_report` (its section
of the raw series), :mod:`.report` (HTML building blocks), :mod:`.plots` (figures),
:mod:`.fleet` (the summary of a fleet of campaigns, ``results/fleet/``).

Each public step function is what one workflow script (``workflow/scripts/*.py``) calls;
the scripts only unpack ``snakemake.input/output/params``. No Snakemake import lives here,
so every step is testable as plain Python.

Files written (the pipeline's output contract, see README):

* ``results/ti/records.csv``: one row per input record: ``timestamp, height_m, bin_id,
  hws_mean_ms, ti_uncorrected, ti_corrected_median, ti_corrected_lo, ti_corrected_hi,
  flags`` (+ ``ti_true`` when the input carries truth, + the Gutiérrez-Antuñano et al. (2018) U/C/PC baselines).
* ``results/ti/bins.csv``: one row per bin (``bin_id`` = case no. of Gutiérrez-Antuñano et al. (2018), Table 1)
  with the bin table, sigma_Z at the bin centre, fit status and diagnostics, and bin means
  of the uncorrected and corrected TI.
* ``results/ti/speed_bins.csv``: per height and speed bin the mean, representative TI and P90 of the corrected TI with intervals of the statistic; ``groups.csv`` (campaign, sectors, sea states) and ``uncertainty_budget.csv`` beside it.
* ``results/ti/metrics.csv``: MD / RMSE of uncorrected, U, C, PC and Bayesian estimates.
* ``results/posterior/bin_<id>.nc`` (one per fitted bin) and ``results/posterior/global.nc``
  (ArviZ DataTree, NetCDF).

Reproducibility: every seed is a ``numpy.random.SeedSequence`` derived from the config
seeds and the bin id (not the batch layout); NetCDF files are written without wall-clock
attributes; CSVs with a fixed float format. A clean rerun is byte-identical in the same
numeric environment (:func:`flidar_uq.threads.numeric_environment`).
"""
