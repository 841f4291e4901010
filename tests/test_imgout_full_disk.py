"""8-bit image writes where the disk (or the process's file size limit) cannot hold the file.

Measured on a 256 KiB tmpfs before the fix: a 300 x 300 RGB PNG write reported success and left a
truncated 258,048-byte file in place of the earlier image (read_image: 'hit end of file in png reader'); a
600 x 600 JPEG write ended the Python process with exit status 1 (libjpeg: 'Output file write error ---
out of disk space?'), leaving its temporary file behind. EXR writes already raised OSError."""
import errno
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from pyshadow.io import read_image, write_image

ROOT = Path(__file__).resolve().parents[1]
resource = pytest.importorskip("resource")


class _Full:
    """An os.statvfs result of a file system with 1 MiB free."""
    f_frsize = 4096
    f_blocks = 1 << 20
    f_bavail = f_bfree = 256


@pytest.mark.parametrize("name", ["view.png", "view.jpg"])
def test_a_full_disk_refuses_the_write_and_keeps_the_image(tmp_path, monkeypatch, name):
    """Was: the PNG write reported success over a truncated file (the earlier image lost); the JPEG write
    ended the process. Now OSError ENOSPC naming the target before anything is written; the image stays."""
    path = tmp_path / name
    write_image(path, np.full((4, 4, 3), 0.5, np.float32))
    before = path.read_bytes()
    monkeypatch.setattr(os, "statvfs", lambda folder: _Full(), raising=False)
    with pytest.raises(OSError) as err:
        write_image(path, np.random.default_rng(0).random((600, 600, 3)).astype(np.float32))
    assert err.value.errno == errno.ENOSPC and err.value.filename == str(path)
    assert path.read_bytes() == before and os.listdir(tmp_path) == [name]
    write_image(path, np.zeros((4, 4, 3), np.float32))          # a small image still fits


def _run(tmp_path, body):
    """Run ``body`` in a fresh interpreter with this checkout's pyshadow first on the path."""
    script = textwrap.dedent("""
        import errno, os, resource, signal, sys
        sys.path.insert(0, sys.argv[1])
        import numpy as np
        import pyshadow.io as pio
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)       # a write beyond the limit fails with EFBIG
        img = np.random.default_rng(0).random((300, 300, 3)).astype(np.float32)
    """) + textwrap.dedent(body)
    return subprocess.run([sys.executable, "-c", script, str(ROOT)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60)


def test_jpeg_beyond_the_file_size_limit_is_an_oserror_not_the_end_of_the_process(tmp_path):
    """Was: with ``ulimit -f`` at 64 KiB the JPEG write of 300 x 300 noise ended the interpreter (exit
    status 1, 'Output file write error --- out of disk space?'). Now OSError EFBIG; the image stays."""
    out = _run(tmp_path, """
        pio.write_image("a.jpg", np.zeros((4, 4), np.float32))
        before = open("a.jpg", "rb").read()
        resource.setrlimit(resource.RLIMIT_FSIZE, (1 << 16, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
        try:
            pio.write_image("a.jpg", img)
            print("written")
        except OSError as e:
            print("refused", errno.errorcode[e.errno], e.filename)
        print(open("a.jpg", "rb").read() == before, sorted(os.listdir(".")))
    """)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.split("\n")[:2] == ["refused EFBIG a.jpg", "True ['a.jpg']"]


def test_a_png_cut_short_is_an_oserror_not_a_truncated_image(tmp_path):
    """Was: a PNG write that failed part way (here the file size limit, unseen as a quota would be)
    reported success; the 65,536-byte truncated file replaced the image and read_image then failed. Now
    OSError (the file is incomplete); the earlier image stays."""
    out = _run(tmp_path, """
        pio.write_image("a.png", np.zeros((4, 4), np.float32))
        before = open("a.png", "rb").read()
        pio._size_limit = lambda: None                      # a limit the check before writing cannot see
        resource.setrlimit(resource.RLIMIT_FSIZE, (1 << 16, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
        try:
            pio.write_image("a.png", img)
            print("written", os.path.getsize("a.png"))
        except OSError as e:
            print("refused", e.filename, "incomplete" in str(e))
        print(open("a.png", "rb").read() == before, sorted(os.listdir(".")))
    """)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.split("\n")[:2] == ["refused a.png True", "True ['a.png']"]


def test_ordinary_writes_still_round_trip(tmp_path):
    """The checks leave ordinary writes alone: PNG and JPEG of every channel count come back."""
    y, x = np.mgrid[0:33, 0:17] / 40.0
    img = np.dstack([y, x, (x + y) / 2]).astype(np.float32)
    for name, a in (("g.png", img[..., 0]), ("c.png", img), ("a.png", np.dstack([img, img[..., :1]])),
                    ("g.jpg", img[..., 0]), ("c.jpeg", img)):
        write_image(tmp_path / name, a)
        back = read_image(tmp_path / name)
        assert back.shape == a.shape[:2] + a.shape[2:]
        assert np.abs(back - a).max() < (0.01 if name.endswith("png") else 0.15)   # JPEG: 4:2:0 chroma
