"""The fit's settings are the library's table (implicitize.FIT_SETTINGS): every one is a
keyword of implicitize.fit, of its stub in __init__.pyi and of python -m implicitize.batch,
and the defaults the package shows are the table's."""

from __future__ import annotations

import ast
import inspect
import subprocess
import sys
from pathlib import Path

import implicitize

# Keywords of implicitize.fit that belong to the Python front end, not to the fit's settings.
FRONT_END = {"mesh", "progress", "memory_limit"}


def names() -> set[str]:
    return {setting["name"] for setting in implicitize.FIT_SETTINGS}


def test_the_table_describes_each_setting():
    assert len(implicitize.FIT_SETTINGS) >= 13
    for setting in implicitize.FIT_SETTINGS:
        assert setting["name"] and setting["unit"] and setting["help"], setting


def test_fit_takes_every_setting_and_nothing_else():
    keywords = set(inspect.signature(implicitize.fit).parameters) - FRONT_END
    assert keywords == names()


def test_the_docstring_describes_every_setting():
    doc = implicitize.fit.__doc__
    for setting in implicitize.FIT_SETTINGS:
        assert f"``{setting['name']}`` ({setting['unit']}" in doc, setting["name"]
        assert setting["help"] in doc, setting["name"]


def test_the_keywords_take_the_table_s_defaults():
    parameters = inspect.signature(implicitize.fit).parameters
    for setting in implicitize.FIT_SETTINGS:
        parameter = parameters[setting["name"]]
        assert parameter.kind is inspect.Parameter.KEYWORD_ONLY
        assert parameter.default is (False if setting["kind"] == "switch" else None), setting


def test_the_stub_declares_every_setting():
    stub = Path(implicitize.__file__).with_name("__init__.pyi")
    tree = ast.parse(stub.read_text())
    fits = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "fit"]
    assert len(fits) == 1
    arguments = fits[0].args
    declared = {a.arg for a in arguments.args + arguments.kwonlyargs} - FRONT_END
    assert declared == names()


def test_the_batch_front_end_takes_every_setting():
    help_text = subprocess.run(
        [sys.executable, "-m", "implicitize.batch", "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    for name in names():
        flag = "--" + name.replace("_", "-")
        assert flag in help_text, f"python -m implicitize.batch has no {flag}"


def test_the_defaults_shown_are_the_table_s():
    for setting in implicitize.FIT_SETTINGS:
        default = setting["default"]
        if default is None or setting["name"] not in implicitize.DEFAULTS:
            continue
        shown = implicitize.DEFAULTS[setting["name"]]
        if isinstance(shown, str):
            assert shown == default, setting
        else:
            assert float(shown) == float(default), setting
