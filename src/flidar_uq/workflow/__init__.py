"""Workflow glue: one function per Snakemake step, report assembly and plots.

Rule: the top layer; may import anything in flidar_uq. ``snakemake`` itself is touched
only in the repository's ``workflow/scripts/``.
"""
