"""Package data: the repository keeps ``models/`` (MJCF) and ``scenarios/`` (YAML) at its top
level; the wheel ships them inside the package as ``simcalib/models`` and
``simcalib/scenarios`` (found by ``simcalib.config.resources``). Everything else is in pyproject.toml.

This file exists only because pyproject's ``packages.find`` cannot add mapped packages to the
ones it finds: new ``simcalib.*`` subpackages are picked up here automatically.
"""

from setuptools import find_packages, setup

DATA_PACKAGES = {"simcalib.models": "models", "simcalib.scenarios": "scenarios"}

setup(
    packages=find_packages(include=["simcalib", "simcalib.*"]) + sorted(DATA_PACKAGES),
    package_dir=DATA_PACKAGES,
    package_data={"simcalib.models": ["*.xml", "**/*"],
                  "simcalib.scenarios": ["*.yaml", "*.yml", "sweeps/*.yaml"]},
)
