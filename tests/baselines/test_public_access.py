"""Baselines and experiments use the envs' public API only: no private attribute of another object."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: ``name._private`` (or ``a.b._private``) where the object is not ``self``/``cls``; dunders are fine.
PRIVATE = re.compile(r"(?<![\w.])((?:\w+\.)*\w+)\._(?!_)[a-z]\w*")


@pytest.mark.parametrize("path", sorted([*ROOT.glob("baselines/**/*.py"), *ROOT.glob("experiments/*.py")]), ids=str)
def test_no_private_access_on_other_objects(path):
    offences = []
    for number, line in enumerate(path.read_text().splitlines(), 1):
        code = line.split("#", 1)[0]
        for match in PRIVATE.finditer(code):
            if match.group(1) not in ("self", "cls", "sys", "os"):
                offences.append(f"{path.relative_to(ROOT)}:{number}: {match.group(0)}")
    assert not offences, "private access (use a public accessor):\n" + "\n".join(offences)
