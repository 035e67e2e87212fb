"""Every script of ``benchmarks/`` and ``scripts/`` imports against the package as it is: a renamed function otherwise
breaks a benchmark only when someone next regenerates its results."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from script_modules import load_script

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted([*(ROOT / "benchmarks").glob("*.py"), *(ROOT / "scripts").glob("*.py")])


@pytest.mark.parametrize("path", SCRIPTS, ids=[f"{p.parent.name}/{p.name}" for p in SCRIPTS])
def test_the_script_imports_against_the_package(path, monkeypatch):
    monkeypatch.syspath_prepend(str(path.parent))  # a benchmark may import its neighbour (rate_check_cases: rate_check)
    module = load_script(path)
    assert callable(getattr(module, "main", None)) or module.__doc__, f"{path.name}: neither main() nor a docstring"
    sys.modules.pop(path.stem, None)
