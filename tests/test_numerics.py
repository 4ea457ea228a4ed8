"""What the last bits of a result depend on (flidar_uq.threads): the numeric environment
the report records, and how far another CPU kernel moves the virtual campaign."""

from __future__ import annotations

import os
import pickle
import platform
import re
import subprocess
import sys

import numpy as np
import pytest

from flidar_uq.campaign.physics_mode import generate_campaign
from flidar_uq.campaign.scenarios import load_scenario
from flidar_uq.threads import SIMD_FUNCTIONS, numeric_environment

X86 = platform.machine() in ("x86_64", "AMD64")
#: OpenBLAS reports its kernel (a DYNAMIC_ARCH build, as in NumPy's wheels), which the
#: environment variable OPENBLAS_CORETYPE chooses; MKL or Accelerate do neither
OPENBLAS_KERNEL = X86 and "kernel)" in numeric_environment()["blas"]
SEED = 20181122


def _python(code: str, env: dict[str, str]) -> str:
    """Run ``code`` in a fresh interpreter (the variables are read when NumPy loads)."""
    return subprocess.run(
        [sys.executable, "-c", code],
        env=os.environ | env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout


def test_numeric_environment_names_every_simd_function_once_and_the_blas_kernels():
    import scipy.linalg  # noqa: F401  (SciPy's own OpenBLAS is loaded too)

    env = numeric_environment()
    assert set(env) == {"machine", "numpy_simd", "blas", "libm"}
    assert env["machine"] == platform.machine()
    if platform.libc_ver()[0] == "glibc":  # the C library and its version, e.g. glibc 2.36
        assert re.fullmatch(r"glibc \d+\.\d+", env["libm"]), env["libm"]
    listed = [
        name
        for part in env["numpy_simd"].split("; ")
        for name in part.split(": ", 1)[1].split(", ")
    ]
    assert sorted(listed) == sorted(SIMD_FUNCTIONS)
    libraries = env["blas"].split("; ")
    assert libraries == sorted(libraries)  # whatever order they were loaded in


@pytest.mark.skipif(not OPENBLAS_KERNEL, reason="an x86-64 OpenBLAS that reports its kernel")
def test_the_openblas_kernel_a_run_uses_shows_in_its_numeric_environment():
    code = "from flidar_uq.threads import numeric_environment as n; print(n()['blas'])"
    assert "(Nehalem kernel)" in _python(code, {"OPENBLAS_CORETYPE": "Nehalem"})


@pytest.mark.slow
@pytest.mark.skipif(not OPENBLAS_KERNEL, reason="an x86-64 OpenBLAS that reports its kernel")
def test_campaign_under_another_openblas_kernel_agrees_to_rounding(tmp_path):
    # another CPU picks another kernel (here the SSE4.2 one, which NumPy 2.5 requires): the campaign's last bits may
    # change (docs/performance.md, session 12), its values agree to rounding
    out = tmp_path / "records.pkl"
    code = (
        "import pickle\n"
        "from flidar_uq.campaign.physics_mode import generate_campaign\n"
        "from flidar_uq.campaign.scenarios import load_scenario\n"
        "sc = load_scenario('default') | {'n_records': 6}\n"
        f"recs = generate_campaign(sc, {SEED}, n_workers=1).records\n"
        f"pickle.dump(recs, open({str(out)!r}, 'wb'))\n"
    )
    _python(code, {"OPENBLAS_CORETYPE": "Nehalem"})
    other = pickle.loads(out.read_bytes())
    here = generate_campaign(load_scenario("default") | {"n_records": 6}, SEED).records
    assert list(other.columns) == list(here.columns)
    for col in here.columns:
        if here[col].dtype.kind == "f":
            np.testing.assert_allclose(
                other[col].to_numpy(), here[col].to_numpy(), rtol=1e-12, atol=1e-12, err_msg=col
            )
        else:
            assert other[col].equals(here[col]), col
