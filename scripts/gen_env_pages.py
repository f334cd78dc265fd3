"""Write the site's env pages from the code: ``docs/envs/<page>.md`` and ``docs/envs/img/<page>.png``.

    python scripts/gen_env_pages.py [--out docs/envs]

For every registered env id the script makes the env with its default config and writes one
page: the observation fields of ``env.layout`` (name, shape, dtype, bounds, and the meaning
and symbolic shape from the module docstring's table), the action space of every
``action_type`` the config allows, the docstring's action, reward and metrics paragraphs,
the config keys with their defaults, and a picture: one ``render_mode="rgb_array"`` frame
after ``reset(seed=0)``. The pages are committed; ``tests/package/test_env_pages.py`` regenerates
them into a temporary directory and compares. Run it after changing an env's layout,
spaces, docstring or defaults.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import inspect
import sys
import typing
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import PIL
from gymnasium import spaces
from PIL import Image, PngImagePlugin

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from docstring_md import markdown_table, rst_to_markdown, simple_tables  # noqa: E402

import teamgym  # noqa: E402
from teamgym.envs.base import TeamEnv  # noqa: E402
from teamgym.envs.spaces import Field  # noqa: E402

OUT = ROOT / "docs" / "envs"
#: The long-form page of each task in docs/ (model, readings, reproduced tables).
TASK_PAGES = {
    "navigation": "navigation.md",
    "exploration": "exploration.md",
    "rendezvous": "rendezvous.md",
    "foraging": "foraging.md",
    "box_pushing": "box_pushing.md",
}
#: Docstring paragraphs taken for the actions and the rewards/metrics sections.
ACTION_PARAGRAPHS = ("Actions", "Action types")
REWARD_PARAGRAPHS = ("Reward", "Metrics")
#: The PNG text key that records the Pillow version a picture was drawn with.
PILLOW_KEY = "teamgym-pillow"


def _task(env_id: str) -> str:
    return teamgym.env_class(env_id).__module__.split(".")[2]


def page_name(env_id: str) -> str:
    """``navigation`` for Navigation-v0, ``box_pushing_v1`` for BoxPushing-v1 (version 0 unsuffixed)."""
    version = env_id.rpartition("-v")[2]
    return _task(env_id) + ("" if version == "0" else f"_v{version}")


def _paragraphs(doc: str) -> list[str]:
    return [p.strip("\n") for p in doc.split("\n\n") if p.strip()]


def _intro(doc: str) -> str:
    """The docstring's paragraphs before the first one on observations."""
    intro = []
    for paragraph in _paragraphs(doc):
        if paragraph.startswith("Observ"):
            break
        intro.append(paragraph)
    return "\n\n".join(intro)


def _sections(doc: str, starts: Sequence[str]) -> list[str]:
    """Paragraphs that begin with one of ``starts``, each with the bullet list that follows it."""
    paragraphs, out = _paragraphs(doc), []
    for i, paragraph in enumerate(paragraphs):
        if paragraph.startswith(starts):
            out.append(paragraph)
            for following in paragraphs[i + 1 :]:
                if not following.startswith("* "):
                    break
                out.append(following)
    return out


def _number(value: float) -> str:
    if np.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:.4g}"


def _bound(values: np.ndarray) -> str:
    """One number when every element agrees, else the last axis' values (all rows agree) or a range."""
    flat = values.reshape(-1, values.shape[-1]) if values.ndim else values.reshape(1, 1)
    if np.all(flat == flat.flat[0]):
        return _number(float(flat.flat[0]))
    if np.all(flat == flat[0]):
        return "(" + ", ".join(_number(float(v)) for v in flat[0]) + ")"
    return f"{_number(float(flat.min()))} … {_number(float(flat.max()))}"


def _documented_fields(doc: str) -> dict[str, tuple[str, str]]:
    """Field name -> (symbolic shape, meaning) from the docstring's tables headed ``field``."""
    fields = {}
    for header, *rows in simple_tables(doc):
        if header[0] != "field" or "meaning" not in header:
            continue
        shape, meaning = header.index("shape"), header.index("meaning")
        for row in rows:
            fields[row[0].strip("`")] = (row[shape], row[meaning])
    return fields


def _shape(shape: tuple[int, ...]) -> str:
    return "(" + ", ".join(map(str, shape)) + ("," if len(shape) == 1 else "") + ")"


def observation_section(env: TeamEnv, doc: str) -> str:
    documented = _documented_fields(doc)
    rows = [["field", "shape", "dtype", "bounds", "meaning"]]
    field: Field
    for field in env.layout.fields:
        low, high = field.bounds()
        symbolic, meaning = documented.get(field.name, ("", ""))
        shape = _shape(field.shape)
        if symbolic and symbolic != shape:
            shape += f" = {symbolic}"
        bounds = f"[{_bound(low)}, {_bound(high)}]"
        rows.append([f"`{field.name}`", shape, np.dtype(field.dtype).name, bounds, rst_to_markdown(meaning)])
    names = {f.name for f in env.layout.fields}
    optional = [
        [f"`{name}`", shape, rst_to_markdown(meaning)] for name, (shape, meaning) in documented.items() if name not in names
    ]
    text = [
        "## Observations",
        "",
        f'Default config: {env.layout.size} float32 values per robot with `obs_format="flat"` (fields in this '
        'order; `env.decode(obs)` splits them), or a `Dict` of these fields with `obs_format="dict"`. '
        "Shape, dtype and bounds are the layout's (`env.layout.fields`; a shape in symbols after `=` and the "
        "meaning are the module docstring's).",
        "",
        markdown_table(rows),
    ]
    if optional:
        text += [
            "",
            "Fields of the docstring's table that the default config does not have (options add them):",
            "",
            markdown_table([["field", "documented shape", "meaning"], *optional]),
        ]
    return "\n".join(text)


def _space(space: spaces.Space) -> str:
    """A space in short form: ``Discrete(13)``, ``Box(low, high, (2,), float32)`` with rounded bounds."""
    if isinstance(space, spaces.Box):
        return f"Box({_bound(space.low)}, {_bound(space.high)}, {_shape(space.shape)}, {space.dtype})"
    return str(space)


def _action_types(env_id: str) -> tuple[str, ...]:
    hints = typing.get_type_hints(teamgym.env_class(env_id).config_class)
    return typing.get_args(hints["action_type"])


def action_section(env_id: str, doc: str) -> str:
    default = teamgym.env_class(env_id).config_class().action_type
    rows = [["`action_type`", "action type", "space (default config)"]]
    for action_type in _action_types(env_id):
        env = teamgym.make(env_id, action_type=action_type)
        try:
            space = env.action_space(env.possible_agents[0])
            name = f"`{action_type}`" + (" (default)" if action_type == default else "")
            rows.append([name, f"`{type(env.action_type).__name__}`", f"`{_space(space)}`"])
        finally:
            env.close()
    prose = [rst_to_markdown(p) for p in _sections(doc, ACTION_PARAGRAPHS)]
    return "\n\n".join(["## Actions", markdown_table(rows), *prose])


def reward_section(doc: str) -> str:
    return "\n\n".join(["## Rewards and metrics", *(rst_to_markdown(p) for p in _sections(doc, REWARD_PARAGRAPHS))])


def config_section(env: TeamEnv) -> str:
    rows = [["key", "type", "default"]]
    for f in dataclasses.fields(env.config):
        rows.append([f"`{f.name}`", f"`{f.type}`", f"`{getattr(env.config, f.name)!r}`"])
    cls = type(env.config)
    return "\n\n".join(
        [
            "## Config",
            f"Keys of `{cls.__module__}.{cls.__name__}` with their defaults (`teamgym.make(id, key=value, ...)`; "
            "the shared keys are described in `EnvConfig`).",
            markdown_table(rows),
        ]
    )


def render_picture(env_id: str, path: Path) -> None:
    """One ``rgb_array`` frame after ``reset(seed=0)`` as a PNG that records the Pillow version."""
    env = teamgym.make(env_id, render_mode="rgb_array")
    try:
        env.reset(seed=0)
        frame = env.render()
    finally:
        env.close()
    info = PngImagePlugin.PngInfo()
    info.add_text(PILLOW_KEY, PIL.__version__)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(frame).save(path, pnginfo=info)


def env_page(env_id: str) -> str:
    cls = teamgym.env_class(env_id)
    module = importlib.import_module(cls.__module__)
    doc = module.__doc__ or ""
    # A class with a docstring of its own (BoxPushingV1: the version history) is described by it,
    # the others by the module docstring's paragraphs before the observations.
    own = inspect.cleandoc(cls.__dict__.get("__doc__") or "")
    summary = own if own and "see the module docstring" not in own.lower() else _intro(doc)
    env = teamgym.make(env_id)
    try:
        task = _task(env_id)
        parts = [
            f"# {env_id}",
            "<!-- Generated by scripts/gen_env_pages.py from the code; do not edit. -->",
            rst_to_markdown(summary),
            f"![{env_id} after reset(seed=0)](img/{page_name(env_id)}.png)",
            f'`teamgym.make("{env_id}")` is `{cls.__module__}.{cls.__name__}` with `{type(env.config).__name__}`; '
            f"{len(env.possible_agents)} agents by default ({', '.join(f'`{a}`' for a in env.possible_agents)}). "
            f"The model, the paper's readings and the reproduced results are in [{TASK_PAGES[task]}](../{TASK_PAGES[task]}); "
            "the API in [Environments](../api/envs.md).",
        ]
        parts += [observation_section(env, doc), action_section(env_id, doc), reward_section(doc), config_section(env)]
    finally:
        env.close()
    return "\n\n".join(parts) + "\n"


def generate(out: Path) -> list[Path]:
    """Write every env's page and picture under ``out``; return the paths written."""
    written = []
    for env_id in teamgym.envs():
        page = out / f"{page_name(env_id)}.md"
        page.parent.mkdir(parents=True, exist_ok=True)
        page.write_text(env_page(env_id), encoding="utf-8")
        picture = out / "img" / f"{page_name(env_id)}.png"
        render_picture(env_id, picture)
        written += [page, picture]
    return written


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT, help="directory of the pages (default docs/envs)")
    args = parser.parse_args(argv)
    for path in generate(args.out):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
