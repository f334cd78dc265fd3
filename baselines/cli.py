"""The command-line toolkit of the ``baselines`` CLIs (evaluate, train, compare, plot_curves, rllib, experiments).

* :class:`Parser`: an ``argparse`` parser whose usage errors are one ``error: ...`` line, exit code 2;
  :func:`parse_args` runs one and turns its exit into a return code;
* argparse ``type`` functions: :func:`at_least`, :func:`nonblank`, :func:`workers_or_ray`, :func:`cluster_address`;
* :func:`parse_pairs` (``KEY=VALUE`` flags such as ``--set``) and :func:`check_out` (an output path
  that can be written), both raising :class:`UsageError`;
* :func:`guarded`: runs a command's work so that a failure is one line and exit code 1
  (``TEAMGYM_TRACEBACK=1`` re-raises), Ctrl-C exit code 130; :func:`one_line` and :func:`message`
  format an error for it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

__all__ = [
    "Parser",
    "UsageError",
    "at_least",
    "check_out",
    "cluster_address",
    "guarded",
    "message",
    "nonblank",
    "one_line",
    "parse_args",
    "parse_pairs",
    "workers_or_ray",
]


class UsageError(ValueError):
    """A command-line or configuration mistake: reported in one line, exit code 2."""


def one_line(text: str) -> str:
    """``text`` with every run of whitespace (newlines included) as one space."""
    return " ".join(text.split())


def message(error: BaseException) -> str:
    """The one-line message of ``error`` (a ``KeyError``'s without the quotes ``str`` adds; else its type name)."""
    if isinstance(error, KeyError) and error.args:
        return one_line(str(error.args[0]))
    return one_line(str(error)) or type(error).__name__


class Parser(argparse.ArgumentParser):
    """An argument parser that reports a bad command line in one line (``error: ...``), exit code 2.

    With ``named`` the line starts with the program's name (``prog: error: ...``, as argparse's does).
    """

    def __init__(self, *args: Any, named: bool = False, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.named = named

    def error(self, message: str) -> NoReturn:
        lead = f"{self.prog}: error" if self.named else "error"
        self.exit(2, f"{lead}: {one_line(message)} (see --help)\n")


def parse_args(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> argparse.Namespace | int:
    """``parser.parse_args(argv)``, or the exit code when it exits (0 after ``--help``, 2 after a usage error)."""
    try:
        return parser.parse_args(argv)
    except SystemExit as done:  # --help, or a usage error already reported in one line
        return 0 if done.code is None else done.code if isinstance(done.code, int) else 2


def at_least(minimum: int, maximum: int | None = None) -> Callable[[str], int]:
    """An argparse ``type``: an integer ``>= minimum`` (and ``<= maximum``)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"must be <= {maximum}, got {value}")
        return value

    return parse


def nonblank(what: str) -> Callable[[str], str]:
    """An argparse ``type``: a ``what`` that is not empty or blank (an empty value would fall back to a default).

    A learned-policy name (``sb3:PATH``, ``rllib:PATH``) must have a ``PATH``.
    """
    from baselines.learned import SCHEMES, split_scheme

    def parse(text: str) -> str:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        split = split_scheme(text)
        if split is not None and not split[1].strip():
            raise argparse.ArgumentTypeError(f"expected {SCHEMES[split[0]]} after {split[0]}:, got {text!r}")
        return text

    return parse


def cluster_address(text: str) -> str:
    """An argparse ``type``: a Ray cluster address (:func:`baselines.runners.check_ray_address`)."""
    from baselines.runners import check_ray_address

    try:
        return check_ray_address(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def workers_or_ray(text: str) -> int | str:
    """An argparse ``type``: a number of worker processes ``>= 1``, or ``ray``."""
    if text.strip().lower() == "ray":
        return "ray"
    try:
        return at_least(1)(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1 or 'ray', got {text!r}") from None


def json_object(text: str) -> dict[str, Any]:
    """An argparse ``type``: a JSON object (``{"key": value, ...}``), e.g. a policy's keyword arguments."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise argparse.ArgumentTypeError(f"expected a JSON object, got {text!r} ({error.msg} at column {error.colno})") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"expected a JSON object {{...}}, got {type(value).__name__} {text!r}")
    return value


def parse_pairs(items: Sequence[str] | None, flag: str = "--set") -> dict[str, str]:
    """``KEY=VALUE`` items of ``flag`` as a dict (keys and values stripped; a later key wins); :class:`UsageError` otherwise."""
    pairs: dict[str, str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"{flag} expects key=value, got {item!r}")
        pairs[key.strip()] = value.strip()
    return pairs


def check_out(out: Path, flag: str = "--out", *, file: bool = False) -> None:
    """Raise :class:`UsageError` (a ``ValueError``) if ``out`` cannot be made an output directory.

    It cannot when it is an existing file, lies under a file, or when it (if it exists) or its
    nearest existing ancestor is a directory this process may not write into. With ``file``,
    ``out`` names a file to write: it must not be a directory, and its directory is checked.
    """
    shown = repr(str(out))
    try:
        if file and out.is_dir():
            raise UsageError(f"{flag} {shown} is a directory, not a file")
        for path in out.parents if file else (out, *out.parents):
            if not path.exists():
                continue
            if not path.is_dir():
                where = "is an existing file" if path == out else f"is under {str(path)!r}, which is a file"
                raise UsageError(f"{flag} {shown} {where}, not a directory")
            if not os.access(path, os.W_OK | os.X_OK):
                where = "" if path == out else f" under {str(path)!r}"
                raise UsageError(f"{flag} {shown}: cannot write{where} (permission denied)")
            return
    except UsageError:
        raise
    except (OSError, ValueError) as error:  # e.g. a NUL byte or a name too long
        raise UsageError(f"{flag} {shown} is not a usable path: {error}") from None


def guarded(body: Callable[[], int]) -> int:
    """Run a command's work: Ctrl-C exits 130, any failure prints one line and exits 1 (``TEAMGYM_TRACEBACK=1`` re-raises)."""
    try:
        return body()
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except Exception as error:  # noqa: BLE001 - no traceback reaches a command-line user
        if os.environ.get("TEAMGYM_TRACEBACK"):
            raise
        print(f"error: {type(error).__name__}: {message(error)} (TEAMGYM_TRACEBACK=1 shows where)", file=sys.stderr)
        return 1
