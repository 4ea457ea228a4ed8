"""flidar_uq: motion-induced turbulence-intensity error of floating lidars.

VAD motion simulator (Gutiérrez-Antuñano et al., 2018), emcee inference of the correlation rho and the
per-bin motion parameters, and corrected TI with credible intervals.
See docs/conventions.md for frames and names, docs/interfaces.md for the module map and
docs/library.md for the correction as a library, in memory:

    records = flidar_uq.read_records("records.csv")        # validated record table
    qc = flidar_uq.run_qc(records)                          # QC flags, kept records
    fit = flidar_uq.fit_record_model(qc.kept, settings=flidar_uq.SamplerSettings(...))
    result = flidar_uq.correct_campaign(records, fit, **flidar_uq.settings_from_config(),
                                        flags=qc.flags)     # or Reference, CorrectionSettings
    result.to_files("corrected_ti")                         # not a pipeline run's results/
"""

from __future__ import annotations

__version__ = "0.1.0"

#: The user path, imported on first use so that `import flidar_uq` stays cheap (CLI
#: start-up, snakemake parsing): public name -> defining module.
_LAZY = {
    "sigma_z": "flidar_uq.physics.simulator",
    "read_records": "flidar_uq.data.io",
    "QCConfig": "flidar_uq.data.qc",
    "run_qc": "flidar_uq.data.qc",
    "SamplerSettings": "flidar_uq.inference",
    "Priors": "flidar_uq.inference",
    "fit_record_model": "flidar_uq.inference",
    "load_fit": "flidar_uq.inference",
    "save_fit": "flidar_uq.inference",
    "Reference": "flidar_uq.correction.reference",
    "BinTables": "flidar_uq.correction.campaign",
    "CorrectionResult": "flidar_uq.correction.campaign",
    "CorrectionSettings": "flidar_uq.correction.campaign",
    "correct_campaign": "flidar_uq.correction.campaign",
    "settings_from_config": "flidar_uq.workflow.inputs",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'flidar_uq' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])
