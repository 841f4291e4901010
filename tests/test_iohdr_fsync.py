"""Atomic image writes flush the new file's data to disk before the rename that puts it in place."""
import os

import numpy as np
import pytest

from pyshadow.io import write_image


@pytest.mark.parametrize("name, image", [("a.exr", np.full((4, 5, 3), 0.25, np.float32)),
                                         ("a.png", np.full((4, 5), 0.5)),
                                         ("a.jpg", np.zeros((4, 5, 3), np.uint8))])
def test_write_image_fsyncs_the_file_before_the_rename(tmp_path, monkeypatch, name, image):
    """Was: write_image renamed OpenImageIO's temporary file over the target without an fsync (no fsync at
    all during the write): on ext4 (delayed allocation) a crash soon after could leave an empty file in place
    of both the old and the new image. Now the file that ends up at ``path`` is fsynced, complete, before
    os.replace."""
    events = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        st = os.fstat(fd)
        events.append(("fsync", st.st_ino, st.st_size))
        return real_fsync(fd)

    def replace(src, dst, *a, **k):
        events.append(("replace", os.stat(src).st_ino, os.stat(src).st_size))
        return real_replace(src, dst, *a, **k)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    path = tmp_path / name
    path.write_bytes(b"old")
    write_image(path, image)
    st = os.stat(path)
    assert st.st_size > 100
    done = events.index(("replace", st.st_ino, st.st_size))
    assert ("fsync", st.st_ino, st.st_size) in events[:done]


@pytest.mark.parametrize("code, fails", [(5, True), (22, False), (95, False)])     # EIO; EINVAL, ENOTSUP
def test_write_image_reports_a_failed_fsync_and_keeps_the_old_file(tmp_path, monkeypatch, code, fails):
    """Was: nothing was fsynced, so an I/O error on flushing the data (EIO) went unseen and the new file
    replaced the old one. Now EIO is an OSError naming the target, which keeps its old bytes, and no temporary
    file is left; a file system that cannot sync at all (EINVAL, ENOTSUP) is passed over."""
    def fsync(fd):
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(os, "fsync", fsync)
    path = tmp_path / "a.png"
    path.write_bytes(b"old")
    if fails:
        with pytest.raises(OSError) as info:
            write_image(path, np.full((4, 5), 0.5))
        assert info.value.errno == code and info.value.filename == str(path)
        assert path.read_bytes() == b"old"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]
    else:
        write_image(path, np.full((4, 5), 0.5))
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
