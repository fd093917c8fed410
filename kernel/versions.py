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
