"""A write over an existing read-only file: refused as opening it for writing would be, the file kept."""
import os
import subprocess
import textwrap
from pathlib import Path

import pytest

from conftest import unprivileged_python

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(unprivileged_python() is None, reason="needs a POSIX user without CAP_DAC_OVERRIDE")
def test_a_read_only_file_is_not_replaced(tmp_path):
    """Was: write_image over a PNG or EXR of mode 0444 (and write_bytes_atomic over any such file) in a
    writable folder replaced it without a word -- the rename ignores the file's own permission, so a
    render a user had write-protected was lost (and the new file was made 0444 in turn), where
    open(path, "wb"), PIL or OpenImageIO itself refuse (and os.replace on Windows). Now PermissionError
    (EACCES) naming the file before anything is written; the file keeps its bytes, nothing is left beside
    it."""
    names = ("a.png", "a.exr", "a.bin")
    for name in names:
        (tmp_path / name).write_bytes(b"precious " + name.encode())
        (tmp_path / name).chmod(0o444)
    tmp_path.chmod(0o777)
    script = textwrap.dedent("""
        import errno, os, sys
        sys.path.insert(0, sys.argv[1])
        import numpy as np
        from pyshadow.io import write_image
        from pyshadow._files import write_bytes_atomic
        for name in sys.argv[3:]:
            path = os.path.join(sys.argv[2], name)
            try:
                if name.endswith(".bin"):
                    write_bytes_atomic(path, b"new")
                else:
                    write_image(path, np.zeros((2, 3), np.float32))
                print(name, "written")
            except OSError as e:
                print(name, type(e).__name__, errno.errorcode.get(e.errno), e.filename == path)
    """)
    try:
        out = subprocess.run(unprivileged_python() + ["-c", script, str(ROOT), str(tmp_path), *names],
                             capture_output=True, text=True, timeout=60)
    finally:
        tmp_path.chmod(0o755)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.split("\n")[:3] == [f"{n} PermissionError EACCES True" for n in names]
    for name in names:
        assert (tmp_path / name).read_bytes() == b"precious " + name.encode()
    assert sorted(os.listdir(tmp_path)) == sorted(names)
