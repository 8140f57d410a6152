"""The install (issue 30): an SPDX licence, a lean core, one extra per use, each missing extra
named with its pip install; `make demo` installs the core, `make test` everything."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from inertest.errors import EXTRAS

ROOT = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _name(req: str) -> str:
    return re.split(r"[\[<>=!~ ;]", req, maxsplit=1)[0].lower().replace("_", "-")


def test_licence_is_an_spdx_string_with_its_file():
    """A licence table made setuptools >= 77 warn three times per build."""
    project = PROJECT["project"]
    assert project["license"] == "MIT"
    assert all((ROOT / f).is_file() for f in project["license-files"])
    assert "MIT License" in (ROOT / "LICENSE").read_text()
    assert any(r.startswith("setuptools>=77") for r in PROJECT["build-system"]["requires"])


def test_the_core_holds_what_the_main_job_needs_and_the_rest_are_extras():
    core = {_name(r) for r in PROJECT["project"]["dependencies"]}
    assert core == {"numpy", "scipy", "click", "rich", "pyarrow", "matplotlib", "numba",
                    "sqlalchemy", "alembic", "pyyaml", "threadpoolctl"}
    extras = PROJECT["project"]["optional-dependencies"]
    packages = {"rosbags": "ros", "pyulog": "px4", "nptdms": "tdms", "h5py": "hdf5",
                "psycopg": "postgres", "scikit-learn": "neural", "sympy": "symbolic",
                "pandas": "pandas"}
    for package, extra in packages.items():
        assert package in {_name(r) for r in extras[extra]}, (package, extra)
    assert set(EXTRAS.values()) == set(packages.values())  # each import names its extra
    everything = re.search(r"\[(.*)\]", extras["all"][0]).group(1).split(",")
    assert set(everything) == set(packages.values())
    assert "inertest[all]" in extras["test"] and "pytest" in {_name(r) for r in extras["test"]}


def test_make_demo_installs_the_core_and_make_test_everything():
    make = (ROOT / "Makefile").read_text()
    demo_deps = re.search(r"^demo: (.+)$", make, re.M).group(1).split()
    assert demo_deps == ["$(CORE)"]
    assert re.search(r"^\$\(CORE\):.*\n(?:\t.*\n)*?\t\$\(BIN\)/python -m pip install -e \.\n",
                     make, re.M)
    assert re.search(r"-m pip install -e '\.\[test\]'", make)
    assert re.search(r"^lint: \$\(FULL\)$", make, re.M)
