"""Names the bake package's docstrings give as pyshadow.bake.NAME exist there."""
import re
from pathlib import Path

import pyshadow
import pyshadow.bake


def test_every_pyshadow_bake_name_in_the_docstrings_exists():
    """Was: the package's docstring pointed to bake_frames and bake_frames' to pyshadow.bake.read_motion, but
    pyshadow.bake.bake_frames raised AttributeError (they lived in pyshadow.bake.frames and .motion only)."""
    root = Path(pyshadow.__file__).parent
    names = set()
    for path in root.rglob("*.py"):
        names |= set(re.findall(r":(?:func|class|data):`~?pyshadow\.bake\.([A-Za-z_]\w*)`", path.read_text()))
    names |= set(re.findall(r":func:`(\w+)`", pyshadow.bake.__doc__))
    assert {"bake_frames", "read_motion"} <= names
    modules = {"frames", "library", "motion", "params", "records", "runner", "assets", "cli"}
    missing = [n for n in sorted(names - modules) if not hasattr(pyshadow.bake, n)]
    assert missing == []
    assert pyshadow.bake.bake_frames is pyshadow.bake.frames.bake_frames
