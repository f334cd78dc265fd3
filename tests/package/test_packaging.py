"""Release metadata agrees with itself, the package data cover the shipped files, and the docs hooks work.

``scripts/check_wheel.sh`` builds the wheel and checks the installed package; these tests keep
the files it relies on in step without building anything.
"""

import fnmatch
import importlib.util
import re
import subprocess
import tomllib
from pathlib import Path

import pytest

import teamgym

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
_spec = importlib.util.spec_from_file_location("mkdocs_hooks", ROOT / "scripts" / "mkdocs_hooks.py")
hooks = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hooks)


def test_versions_agree():
    version = PYPROJECT["project"]["version"]
    assert teamgym.__version__ == version
    citation = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert re.search(r"^version: (\S+)$", citation, re.MULTILINE).group(1) == version
    assert re.search(r'^date-released: "\d{4}-\d{2}-\d{2}"$', citation, re.MULTILINE)
    assert re.search(r"^cff-version: 1\.2\.0$", citation, re.MULTILINE)


def test_license_is_declared_and_shipped():
    project = PYPROJECT["project"]
    assert project["license"] == "MIT"
    assert all((ROOT / f).is_file() for f in project["license-files"])
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License") and "Copyright (c) 2026 teamgym developers" in text
    assert not any(c.startswith("License ::") for c in project["classifiers"]), "license classifiers and an SPDX license conflict"


def test_changelog_names_every_env_id():
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "## [Unreleased]" in changelog
    assert f"## [{PYPROJECT['project']['version']}]" in changelog
    missing = [e for e in teamgym.envs() if f"`{e}`" not in changelog]
    assert not missing, f"CHANGELOG.md does not describe {missing}"


def _tracked(package: str) -> list[str]:
    try:
        out = subprocess.run(["git", "ls-files", package], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [line for line in out.splitlines() if not line.endswith(".py")]


@pytest.mark.parametrize("package", ["teamgym", "baselines"])
def test_package_data_cover_every_tracked_data_file(package):
    patterns = PYPROJECT["tool"]["setuptools"]["package-data"][package]
    files = _tracked(package)
    assert files, f"no data files tracked under {package}/"
    missed = [f for f in files if not any(fnmatch.fnmatch(f[len(package) + 1 :], p) for p in patterns)]
    assert not missed, f"not in [tool.setuptools.package-data] {package}: {missed}"


def test_every_readme_include_of_the_docs_names_sections_that_exist():
    includes = [m for page in (ROOT / "docs").rglob("*.md") for m in hooks._INCLUDE.findall(page.read_text(encoding="utf-8"))]
    assert includes, "docs/index.md and docs/reproductions.md include README sections"
    for include in includes:
        assert hooks.readme_sections([p.strip() for p in include.split("|")]).strip()


def test_readme_sections_picks_by_title_prefix(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("# t\n\nintro\n\n## Reproduced: a\n\nA\n\n## Other\n\nO\n\n## Reproduced: b\n\nB\n")
    assert hooks.readme_sections(["Reproduced:"], readme) == "## Reproduced: a\n\nA\n\n## Reproduced: b\n\nB"
    assert hooks.readme_sections(["(intro)", "Other"], readme) == "intro\n\n## Other\n\nO"
    with pytest.raises(ValueError, match="no section starting with"):
        hooks.readme_sections(["Missing"], readme)


def test_links_resolve_from_where_they_were_written(tmp_path, monkeypatch):
    monkeypatch.setattr(hooks, "ROOT", tmp_path)
    docs = tmp_path / "docs"
    (docs / "figures").mkdir(parents=True)
    (docs / "page.md").write_text("")
    (tmp_path / "src.py").write_text("")
    text = "[p](docs/page.md#x) ![i](docs/figures) [code](src.py) [gone](nothing.md) [web](https://example.org)\n```\n[f](src.py)\n```"
    out = hooks.rewrite_links(text, tmp_path, docs / "sub", docs)
    assert (
        out.splitlines()[0]
        == "[p](../page.md#x) i (`docs/figures`) code (`src.py`) [gone](nothing.md) [web](https://example.org)"
    )
    assert "[f](src.py)" in out
