"""The data files shipped inside the package (package data, read with importlib.resources).

- ``config.schema.yaml``: the closed JSON schema of the pipeline's config
  (:data:`flidar_uq.workflow.inputs.SCHEMA_PATH`), read by ``flidar-uq validate --config``
  and by the workflow before any job;
- ``scenarios/<name>.yaml``: the virtual-campaign scenarios
  (:func:`flidar_uq.campaign.scenarios.scenario_dir`, ``scenarios/README.md``);
- ``examples/hand_written_campaign.csv``: a 30-record table of the user's format, the
  example of docs/library.md.

The schema and scenarios are the only copies: the workflow reads them from the installed package too, so an
editable and a non-editable ``pip install`` find the same files.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

__all__ = ["resource_path"]


def resource_path(*parts: str) -> Path:
    """Path of a file or directory shipped under ``flidar_uq/resources/``.

    Parameters
    ----------
    *parts : str
        Path components below ``flidar_uq/resources/``, e.g. ``"scenarios", "tiny.yaml"``.

    Returns
    -------
    Path
        The file's path in the installed package (Snakemake needs real files as inputs).

    Raises
    ------
    FileNotFoundError
        If the package was installed without its data files.
    """
    res = files(__name__).joinpath(*parts)
    if not isinstance(res, Path):  # a zipped install: no file system path to hand out
        raise FileNotFoundError(
            f"flidar_uq resource {'/'.join(parts)!r} is not a file on disk ({res!r}); "
            "install flidar_uq unzipped (pip install)"
        )
    if not res.exists():
        raise FileNotFoundError(
            f"flidar_uq resource {'/'.join(parts)!r} missing at {res} "
            "(package data not installed: reinstall flidar_uq)"
        )
    return res
