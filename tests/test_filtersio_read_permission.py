"""An image file this process may not read: the system's PermissionError, not a ValueError."""
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest

from pyshadow.io import write_image

from conftest import unprivileged_python

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(unprivileged_python() is None, reason="needs a POSIX user without CAP_DAC_OVERRIDE")
def test_an_unreadable_image_is_a_permission_error_naming_it(tmp_path):
    """Was: ValueError 'cannot read image ...: Could not open "..." (Permission denied)' for an EXR, PNG
    or JPEG of mode 000 (OpenImageIO's message wrapped as unreadable contents): a caller catching
    PermissionError (or OSError) to skip files it may not read missed it, and one catching ValueError
    for corrupt files took it for a corrupt file. Now PermissionError (EACCES) naming the file."""
    names = ("a.exr", "a.png", "a.jpg")
    for name in names:
        write_image(tmp_path / name, np.full((2, 3), 0.5, np.float32))
        (tmp_path / name).chmod(0)
    script = textwrap.dedent("""
        import errno, os, sys
        sys.path.insert(0, sys.argv[1])
        from pyshadow.io import read_image
        for name in sys.argv[3:]:
            path = os.path.join(sys.argv[2], name)
            try:
                read_image(path)
                print(name, "read")
            except Exception as e:
                print(name, type(e).__name__, errno.errorcode.get(getattr(e, "errno", None)),
                      getattr(e, "filename", None) == path)
    """)
    try:
        out = subprocess.run(unprivileged_python() + ["-c", script, str(ROOT), str(tmp_path), *names],
                             capture_output=True, text=True, timeout=60)
    finally:
        for name in names:
            (tmp_path / name).chmod(0o644)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.split("\n")[:3] == [f"{n} PermissionError EACCES True" for n in names]
