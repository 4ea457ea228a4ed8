"""flidar_uq: motion-induced turbulence-intensity error of floating lidars.

VAD motion simulator (Gutiérrez-Antuñano et al., 2018), emcee inference of the correlation rho and the
per-bin motion parameters, and corrected TI with credible intervals.
See docs/conventions.md for frames and names, docs/interfaces.md for the module map.
"""

from __future__ import annotations

__version__ = "0.1.0"
__all__ = ["sigma_z", "__version__"]


def __getattr__(name: str):
    # Lazy so that `import flidar_uq` stays cheap (CLI start-up, snakemake parsing).
    if name == "sigma_z":
        from flidar_uq.physics.simulator import sigma_z

        return sigma_z
    raise AttributeError(f"module 'flidar_uq' has no attribute {name!r}")
