"""The declared lower bounds, the floor constraints CI tests them with, and the packaged files.

``pyproject.toml`` declares a lower bound for every dependency; ``scripts/constraints-floors.txt``
pins each of them exactly, and ``scripts/run_tests_floors.sh`` runs the whole suite in a venv
built with those pins (``TEAMGYM_FLOORS=1``), beside the usual run with the latest versions.
"""

import os
import re
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
CONSTRAINTS = ROOT / "scripts" / "constraints-floors.txt"
FLOORS_SCRIPT = ROOT / "scripts" / "run_tests_floors.sh"
PROJECT = canonicalize_name(PYPROJECT["project"]["name"])


def _requirements() -> list[Requirement]:
    """Every requirement of the core and the extras, but an extra's reference to another (``teamgym[train]``)."""
    project = PYPROJECT["project"]
    reqs = [Requirement(r) for r in project["dependencies"]]
    for extra in project["optional-dependencies"].values():
        reqs += [Requirement(r) for r in extra]
    return [r for r in reqs if canonicalize_name(r.name) != PROJECT]


def _floor_run_extras() -> list[str]:
    """The extras ``run_tests_floors.sh`` installs (its ``pip install -e '.[...]'``)."""
    (extras,) = re.findall(r"-e \"?'?\.\[([\w,-]+)\]", FLOORS_SCRIPT.read_text())
    return extras.split(",")


def _pins() -> dict[str, Version]:
    pins = {}
    for line in CONSTRAINTS.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, _, version = line.partition("==")
            assert version, f"{CONSTRAINTS.name}: {line!r} is not pinned with =="
            pins[canonicalize_name(name)] = Version(version)
    return pins


def _lower_bound(req: Requirement) -> Version | None:
    bounds = [Version(s.version) for s in req.specifier if s.operator in (">=", "==")]
    return max(bounds) if bounds else None


def test_every_dependency_declares_a_floor_pinned_in_the_constraints():
    pins = _pins()
    names = set()
    for req in _requirements():
        name = canonicalize_name(req.name)
        names.add(name)
        floor = _lower_bound(req)
        assert floor is not None, f"{req} has no lower bound"
        assert name in pins, f"{req.name} is not pinned in {CONSTRAINTS.name}"
        assert pins[name] == floor, f"{CONSTRAINTS.name} pins {req.name}=={pins[name]}, pyproject.toml's floor is {floor}"
        assert req.specifier.contains(pins[name], prereleases=True), (req, pins[name])
    assert set(pins) == names, f"pins without a declared dependency: {sorted(set(pins) - names)}"


def test_the_floor_run_installs_the_test_extras():
    extras = _floor_run_extras()
    assert set(extras) == {"train", "dev", "bench", "gambit"}, extras
    assert set(extras) <= set(PYPROJECT["project"]["optional-dependencies"])


def test_an_extra_names_only_declared_extras_of_the_project():
    declared = set(PYPROJECT["project"]["optional-dependencies"])
    for extra, requirements in PYPROJECT["project"]["optional-dependencies"].items():
        for req in map(Requirement, requirements):
            if canonicalize_name(req.name) == PROJECT:
                assert req.extras and req.extras <= declared - {extra}, f"extra {extra!r}: {req} names no other declared extra"


def test_gymnasium_1_2_stays_allowed():
    # ray[rllib] pins gymnasium==1.2.2; teamgym must install beside it.
    (gym,) = [r for r in _requirements() if canonicalize_name(r.name) == "gymnasium"]
    assert gym.specifier.contains("1.2.2")


@pytest.mark.skipif(os.environ.get("TEAMGYM_FLOORS") != "1", reason="only in the floor run (scripts/run_tests_floors.sh)")
def test_the_floor_run_has_the_floors_installed():
    # The floor run installs the core and the extras its script names: not rllib (ray pins gymnasium
    # 1.2.2; it has its own venv), docs (scripts/build_docs.sh) or notebooks.
    project = PYPROJECT["project"]
    wanted = [Requirement(r) for r in project["dependencies"]]
    for extra in _floor_run_extras():
        wanted += [Requirement(r) for r in project["optional-dependencies"][extra]]
    names = {canonicalize_name(r.name) for r in wanted}
    installed = {name: Version(metadata.version(name)) for name in _pins() if name in names}
    wrong = {name: str(v) for name, v in installed.items() if v.release != _pins()[name].release or v.pre != _pins()[name].pre}
    assert not wrong, f"installed versions differ from {CONSTRAINTS.name}: {wrong}"


def test_py_typed_is_shipped():
    assert (ROOT / "teamgym" / "py.typed").is_file()
    assert "py.typed" in PYPROJECT["tool"]["setuptools"]["package-data"]["teamgym"]
