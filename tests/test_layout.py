"""The layout stays one room per job (docs/architecture.md): no Python module over 600
lines, no class over 300, no kernel file or header over 400."""
import ast

import pytest

from conftest import REPO

MODULE_LINES, CLASS_LINES, KERNEL_LINES = 600, 300, 400


def _python_files():
    return sorted(p for folder in ("pyshadow", "tests", "benchmarks", "examples")
                  for p in (REPO / folder).rglob("*.py"))


@pytest.mark.parametrize("path", _python_files(), ids=lambda p: str(p.relative_to(REPO)))
def test_python_module_and_class_sizes(path):
    text = path.read_text()
    assert len(text.splitlines()) <= MODULE_LINES, f"{path.name}: split it by job"
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ClassDef):
            n = node.end_lineno - node.lineno + 1
            assert n <= CLASS_LINES, f"{path.name}: class {node.name} has {n} lines"


def test_kernel_file_sizes():
    files = sorted((REPO / "kernels").glob("*.[ch]*"))
    assert len(files) >= 10
    big = {p.name: n for p in files if (n := len(p.read_text().splitlines())) > KERNEL_LINES}
    assert not big, f"kernel files over {KERNEL_LINES} lines: {big}"
