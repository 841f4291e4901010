"""pyshadow-bench --method vtk-ssao with more samples than VTK's SSAO kernel takes."""
import pytest

from pyshadow.bench import cli
from pyshadow.bench.common import UsageError
from pyshadow.bench.method_sweep import check_camera


class _Stop(Exception):
    """Raised in place of the single benchmark."""


def test_vtk_ssao_above_vtks_kernel_is_a_usage_error(monkeypatch, tmp_path, capsys):
    """Was: --method vtk-ssao --samples 4096 ran the other methods and then failed at the vtk-ssao row (VTK
    clamps its kernel to 1000 samples; vtk_ssao refuses more). Now exit 2 before any work."""
    def fake_run(*a, **kw):
        raise _Stop

    monkeypatch.setattr(cli, "run_main", fake_run)
    with pytest.raises(SystemExit) as e:
        cli.main(["--method", "vtk-ssao", "--samples", "4096", "--size", "64x48", "--quiet", "--no-cache",
                  "--out", str(tmp_path / "out")])
    assert e.value.code == 2
    assert "at most 1000 samples" in capsys.readouterr().err
    with pytest.raises(_Stop):                      # VTK's largest is accepted
        cli.main(["--method", "vtk-ssao", "--samples", "1000", "--size", "64x48", "--quiet", "--no-cache",
                  "--out", str(tmp_path / "out")])


def test_check_camera_counts_every_sweep_setting():
    """The sweep's sample counts: the largest decides; other methods take any count."""
    cam = type("Cam", (), {"width": 64, "height": 48})()
    with pytest.raises(UsageError, match="1024"):
        check_camera(["csm", "vtk-ssao"], cam, (16, 1024, 64))
    check_camera(["csm", "vtk-ssao"], cam, (16, 1000))
    check_camera(["csm", "embree"], cam, (4096,))
