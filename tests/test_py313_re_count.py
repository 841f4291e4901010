"""Python 3.13 deprecates passing ``count``, ``maxsplit`` or ``flags`` to the module-level ``re.sub``,
``re.subn`` and ``re.split`` by position (a DeprecationWarning, which pytest's filterwarnings=error makes a
failure): on 3.13 every binary PLY (``ply_ascii``) and every PLY of concave polygons (``ply_polygons``) failed
to load under the test suite. They are passed by keyword."""
import ast
import struct
import warnings

import pytest

from conftest import REPO
from pyshadow.mesh_files import ply_ascii, ply_polygons

_POSITIONAL = {"sub": 3, "subn": 3, "split": 2}     # positional arguments a call may have: pattern, repl, string


def _positional_re_calls():
    found = []
    for path in sorted((REPO / "pyshadow").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and isinstance(node.func.value, ast.Name) and node.func.value.id == "re"
                    and len(node.args) > _POSITIONAL.get(node.func.attr, len(node.args))):
                found.append(f"{path.relative_to(REPO)}:{node.lineno} re.{node.func.attr}")
    return found


def test_re_count_and_flags_are_keywords():
    """Was: pyshadow/mesh_files.py's two ``re.sub(..., 1)`` calls (the count by position)."""
    assert not _positional_re_calls()


@pytest.mark.parametrize("form", ["binary_little_endian", "binary_big_endian"])
def test_binary_ply_of_polygons_turns_to_ascii_without_warnings(form):
    """A binary PLY of a quad: its ASCII text, then the quad as two triangles (on 3.13 a DeprecationWarning)."""
    order = "<" if form == "binary_little_endian" else ">"
    head = (f"ply\nformat {form} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar uint vertex_indices\nend_header\n").encode()
    corners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    body = b"".join(struct.pack(order + "3f", *c) for c in corners) + struct.pack(order + "B4I", 4, 0, 1, 2, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        text = ply_ascii(head + body)
        split = ply_polygons(text, split=True)
    assert text.startswith(b"ply\nformat ascii 1.0\n") and text.endswith(b"4 0 1 2 3\n")
    assert b"\nelement face 2\n" in split and split.count(b"\nformat ") == 1
