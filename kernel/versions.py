"""The versions of Python and of the packages drivebench's results depend on, as every
stage records them (manifests, the report's provenance section)."""

from __future__ import annotations

import functools
import platform
from importlib import metadata

#: distributions whose versions are recorded
PACKAGES = (
    "drivebench", "numpy", "pandas", "scipy", "statsmodels", "pyarrow", "casadi",
    "matplotlib", "jinja2", "npTDMS", "distributed",
)


def package_versions() -> dict[str, str]:
    """``{"python": ..., name: version}`` for each of :data:`PACKAGES` ("not installed"
    for one that is absent)."""
    versions = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


#: asks IPOPT for its version (``GetIpoptVersion``) in a child Python
_IPOPT_VERSION = """
import ctypes, pathlib, casadi
lib = ctypes.CDLL(str(pathlib.Path(casadi.__file__).parent / "libipopt.so"))
parts = [ctypes.c_int() for _ in range(3)]
lib.GetIpoptVersion(*(ctypes.byref(p) for p in parts))
print(".".join(str(p.value) for p in parts))
"""


@functools.cache
def ipopt_version() -> str:
    """The version of the IPOPT library CasADi loads, as the library states it
    (``GetIpoptVersion``), or ``"not found (...)"``.

    Asked in a child process: loading IPOPT here would load its BLAS before the solve
    code sets its thread count (:mod:`optimize.solve.nlp_solver`), which it reads once; asked
    once per process.
    """
    import subprocess
    import sys

    try:
        done = subprocess.run([sys.executable, "-c", _IPOPT_VERSION], capture_output=True,
                              text=True, timeout=60, check=False)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"not found ({exc})"
    if done.returncode != 0:
        return f"not found ({done.stderr.strip().splitlines()[-1:]})"
    return done.stdout.strip()


def version_text() -> str:
    """What ``bench --version`` prints: drivebench's version and the solvers it runs on."""
    v = package_versions()
    return (f"drivebench {v['drivebench']} (Python {v['python']}, CasADi {v['casadi']}, "
            f"IPOPT {ipopt_version()})")
