"""docs/architecture.md names every module of the package and every kernel file (helper docs2).

Was: the whole of ``pyshadow/bake/``, ``gltf_files``, ``gltf_materials``, ``mesh_files``, ``csm/exposure``,
``csm/surface_rule``, ``lighting/shadow_fit``, ``visibility/sampled_sky``, a dozen more modules and 11 kernel
headers were in no row of the file that says where each job lives. A module is named when its name (``shadow_fit``
or ``shadow_fit.py``) is a word of a code span on the row of its folder (``lighting/``), or anywhere for a module
of the package's top folder; private modules count (the file lists ``_validate.py`` and ``_compat.py``), the
package files ``__init__.py`` and ``__main__.py`` do not. A kernel file (``.cl``, ``.h``) is named by its file name.
"""
import re

from conftest import REPO

DOC = (REPO / "docs" / "architecture.md").read_text()
PKG = REPO / "pyshadow"
GENERATED = {"scene_types.h"}       # written by pyshadow._cl.tables, not a file of kernels/


def _words(text: str) -> set:
    """The words of the code spans of ``text``."""
    return {w for span in re.findall(r"`([^`\n]+)`", text) for w in re.findall(r"[A-Za-z0-9_]+", span)}


def _rows(folder: str) -> str:
    """The lines of the file that name ``folder/`` (``csm/``, ``pyshadow/_cl/``) in a code span."""
    return "\n".join(line for line in DOC.splitlines()
                     if re.search(r"`(?:pyshadow/)?" + re.escape(folder) + r"/`", line))


def _modules():
    return sorted(p.relative_to(PKG) for p in PKG.rglob("*.py")
                  if p.name not in ("__init__.py", "__main__.py") and "__pycache__" not in p.parts)


def test_every_module_is_named_on_its_folders_row():
    missing = []
    for rel in _modules():
        folder = "/".join(rel.parts[:-1])
        where = _rows(folder) if folder else DOC
        if not where or rel.stem not in _words(where):
            missing.append(str(rel))
    assert not missing, (f"docs/architecture.md does not name {', '.join(missing)}: add each to the row of its "
                         "folder (one phrase: what it does)")


def test_every_package_folder_has_a_row():
    folders = sorted({"/".join(p.parts[:-1]) for p in _modules()} - {""})
    assert not [f for f in folders if not _rows(f)], "a folder of pyshadow/ has no row in docs/architecture.md"


def test_every_kernel_file_is_named():
    files = sorted(p.name for p in (REPO / "kernels").iterdir() if p.suffix in (".cl", ".h"))
    assert len(files) >= 10
    missing = [f for f in files if not re.search(r"(?<![\w.])" + re.escape(f) + r"(?!\w)", DOC)]
    assert not missing, f"docs/architecture.md does not name the kernel files {', '.join(missing)}"


def test_every_file_named_exists():
    """The other way round: a module or kernel file the document names (``name.py``, ``name.cl``,
    ``name.h`` as a code span) is one of the package's or of kernels/."""
    spans = re.findall(r"`([^`\n]+)`", DOC)
    py = {p.name for p in PKG.rglob("*.py")}
    kernels = {p.name for p in (REPO / "kernels").iterdir()} | GENERATED
    gone = [s for s in spans if re.fullmatch(r"[A-Za-z0-9_]+\.py", s) and s not in py]
    gone += [s for s in spans if re.fullmatch(r"[A-Za-z0-9_]+\.(?:cl|h)", s) and s not in kernels]
    assert not gone, f"docs/architecture.md names files that do not exist: {', '.join(gone)}"
