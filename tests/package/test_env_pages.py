"""The committed env pages of the documentation site are what ``scripts/gen_env_pages.py`` makes now."""

import importlib.util
from pathlib import Path

import numpy as np
import PIL
import pytest
from PIL import Image

import teamgym

ROOT = Path(__file__).resolve().parents[2]
PAGES = ROOT / "docs" / "envs"
_spec = importlib.util.spec_from_file_location("gen_env_pages", ROOT / "scripts" / "gen_env_pages.py")
gen = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gen)

HINT = "regenerate with: python scripts/gen_env_pages.py"


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    out = tmp_path_factory.mktemp("envs")
    return out, sorted(p.relative_to(out).as_posix() for p in gen.generate(out))


def test_one_page_and_picture_per_env_id(fresh):
    _, written = fresh
    names = [gen.page_name(e) for e in teamgym.envs()]
    assert len(set(names)) == len(names)
    assert written == sorted([f"{n}.md" for n in names] + [f"img/{n}.png" for n in names])
    committed = sorted(p.relative_to(PAGES).as_posix() for p in PAGES.rglob("*") if p.is_file())
    assert committed == written, f"docs/envs differs from the generator's files; {HINT}"


def test_committed_pages_are_up_to_date(fresh):
    out, written = fresh
    for name in (w for w in written if w.endswith(".md")):
        assert (PAGES / name).read_text(encoding="utf-8") == (out / name).read_text(encoding="utf-8"), f"{name} is stale; {HINT}"


def test_committed_pictures_are_up_to_date(fresh):
    # Pixels are compared with the Pillow that drew the committed picture (its PNG text says which).
    out, written = fresh
    for name in (w for w in written if w.endswith(".png")):
        committed, new = Image.open(PAGES / name), Image.open(out / name)
        assert committed.size == new.size, f"{name}: {committed.size} vs {new.size}; {HINT}"
        if committed.text.get(gen.PILLOW_KEY) == PIL.__version__:
            assert np.array_equal(np.asarray(committed), np.asarray(new)), f"{name} is stale; {HINT}"


def test_page_tables_come_from_the_code():
    page = (PAGES / "navigation.md").read_text(encoding="utf-8")
    env = teamgym.make("Navigation-v0")
    for field in env.layout.fields:
        assert f"| `{field.name}` | {gen._shape(field.shape)}" in page
    assert "| `heading` | `HeadingAction` | `Discrete(5)` |" in page
    assert "Reward per step" in page and "Metrics in" in page
    assert "| `n_robots` | `int` | `3` |" in page


def test_docstring_tables_and_roles_become_markdown():
    md = gen.rst_to_markdown(
        "Fields:\n\n=====  =====\nfield  meaning\n=====  =====\n``a``  first\n       more\n``b``  second\n=====  =====\n\n"
        "See :class:`~teamgym.sim.World` and :func:`teamgym.make`::\n\n    code\n"
    )
    assert "| field | meaning |\n|---|---|\n| ``a`` | first more |\n| ``b`` | second |" in md
    assert "See `World` and `teamgym.make`:\n\n    code" in md
