"""An image written into a folder without write permission: the system's error, not OpenImageIO's."""
import subprocess
import textwrap
from pathlib import Path

import pytest

from conftest import unprivileged_python

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(unprivileged_python() is None, reason="needs a POSIX user without CAP_DAC_OVERRIDE")
def test_a_read_only_folder_is_a_permission_error_naming_the_image(tmp_path):
    """Was: OSError EIO 'OpenImageIO could not open it for writing (Could not open file "<the hidden
    temporary name>")' for a PNG or JPEG (no reason given), EIO for an EXR: a caller catching
    PermissionError missed it. Now PermissionError (EACCES) naming the image, for every format; nothing
    is left in the folder."""
    folder = tmp_path / "ro"
    folder.mkdir()
    script = textwrap.dedent("""
        import errno, os, sys
        sys.path.insert(0, sys.argv[1])
        import numpy as np
        from pyshadow.io import write_image
        for name in ("a.png", "a.jpg", "a.exr"):
            path = os.path.join(sys.argv[2], name)
            try:
                write_image(path, np.zeros((2, 3), np.float32))
                print(name, "written")
            except OSError as e:
                print(name, type(e).__name__, errno.errorcode.get(e.errno), e.filename == path)
        print(os.listdir(sys.argv[2]))
    """)
    folder.chmod(0o555)
    try:
        out = subprocess.run(unprivileged_python() + ["-c", script, str(ROOT), str(folder)], capture_output=True,
                             text=True, timeout=60)
    finally:
        folder.chmod(0o755)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.split("\n")[:4] == ["a.png PermissionError EACCES True", "a.jpg PermissionError EACCES True",
                                          "a.exr PermissionError EACCES True", "[]"]
