"""Installs the repository's top-level folders under the one ``foresight`` namespace.

``core/`` becomes ``foresight.core``, ``api/`` ``foresight.api``, ``store/`` ``foresight.store`` and so on, so no
generic top-level name is claimed (an editable install maps the folders that exist when it runs: after a new
top-level folder appears, ``make install`` reinstalls, since the stamp depends on this file); migrations,
templates, static files, the built-in configs and the shipped model travel as package data.
Everything else (metadata, dependencies, extras) is in pyproject.toml.
"""

from pathlib import Path

from setuptools import setup

HERE = Path(__file__).resolve().parent
CODE = ("core", "api", "worker", "cli", "store")  # Python packages
DATA = ("migrations", "configs", "model")  # run-time data the service reads beside its code


def _packages(folder: str) -> list[str]:
    root = HERE / folder
    if not root.is_dir():
        return []
    subdirs = [root, *(p for p in sorted(root.rglob("*")) if p.is_dir() and "__pycache__" not in p.parts)]
    return [".".join(("foresight", folder, *d.relative_to(root).parts)) for d in subdirs]


folders = [f for f in (*CODE, *DATA) if (HERE / f).is_dir()]
setup(
    packages=["foresight", *(pkg for f in folders for pkg in _packages(f))],
    package_dir={"foresight": "foresight", **{f"foresight.{f}": f for f in folders}},
    package_data={
        "foresight.api": ["web/templates/*", "web/static/*"],
        "foresight.core": [
            "render/*.js"
        ],  # the episode player (the dashboard serves it; compare --local embeds it)
        **{f"foresight.{f}": ["**/*"] for f in DATA},
    },
    exclude_package_data={"": ["*.pyc"]},
)
