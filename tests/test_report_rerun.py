"""The rerun folder (simcalib/report/rerun/): ALL rerun code of simcalib and nothing else —
no module outside it imports rerun, no module in it imports rerun when it is imported (a
run never imports rerun), and it stays in small pieces."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "simcalib"
RERUN_DIR = PKG / "report" / "rerun"


def _rerun_imports(tree) -> list[tuple[int, bool]]:
    """``(line, at module level)`` of every import of rerun in a module's tree."""
    top = {id(n) for n in tree.body}
    out = []
    for node in ast.walk(tree):
        names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                 [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level
                 else [])
        if any(n == "rerun" or n.startswith("rerun.") for n in names):
            out.append((node.lineno, id(node) in top))
    return out


@pytest.mark.slow
def test_only_the_rerun_folder_imports_rerun_and_only_lazily():
    outside, eager = [], []
    for p in PKG.rglob("*.py"):
        found = _rerun_imports(ast.parse(p.read_text()))
        if RERUN_DIR in p.parents:
            eager += [f"{p.name}:{line}" for line, top in found if top]
        elif found:
            outside.append(f"{p.relative_to(PKG)}:{found[0][0]}")
    assert not outside, f"rerun imported outside simcalib/report/rerun: {outside}"
    assert not eager, f"rerun imported at module level: {eager}"


def test_rerun_modules_and_functions_stay_small():
    big = []
    for p in RERUN_DIR.glob("*.py"):
        src = p.read_text()
        if src.count("\n") > 600:
            big.append(f"{p.name}: {src.count(chr(10))} lines")
        for node in ast.walk(ast.parse(src)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > 60:
                    big.append(f"{p.name}:{node.name}: {n} lines")
    assert not big, big
