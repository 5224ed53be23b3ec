"""Maps the repository's layer folders into the ``gaitcap`` namespace: ``acquisition/`` installs as
``gaitcap.acquisition``, ``reconstruction/`` as ``gaitcap.reconstruction``, and so on. Everything else
about the distribution is in pyproject.toml."""

from setuptools import find_packages, setup

LAYERS = ("acquisition", "reconstruction", "services", "api", "simulator")


def _layer_packages(layer: str) -> list[str]:
    return [f"gaitcap.{layer}"] + [f"gaitcap.{layer}.{sub}" for sub in find_packages(layer)]


setup(
    packages=[pkg for layer in LAYERS for pkg in _layer_packages(layer)],
    package_dir={f"gaitcap.{layer}": layer for layer in LAYERS},
)
