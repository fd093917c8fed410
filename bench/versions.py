"""The versions of Python and of the packages drivebench's results depend on, as every
stage records them (manifests, the report's provenance section)."""

from __future__ import annotations

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


def ipopt_version() -> str:
    """The version of the IPOPT library CasADi loads (its ``GetIpoptVersion``), or
    ``"not found (...)"`` when the library or the function is absent."""
    import ctypes
    from pathlib import Path

    try:
        import casadi

        lib = ctypes.CDLL(str(Path(casadi.__file__).parent / "libipopt.so"))
        parts = [ctypes.c_int() for _ in range(3)]
        lib.GetIpoptVersion(*(ctypes.byref(p) for p in parts))
    except (ImportError, OSError, AttributeError) as exc:
        return f"not found ({exc})"
    return ".".join(str(p.value) for p in parts)


def version_text() -> str:
    """What ``bench --version`` prints: drivebench's version and the solvers it runs on."""
    v = package_versions()
    return (f"drivebench {v['drivebench']} (Python {v['python']}, CasADi {v['casadi']}, "
            f"IPOPT {ipopt_version()})")
