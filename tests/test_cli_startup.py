"""`tognet --help` and every command's help start without the heavy libraries (torch, trimesh)."""

import subprocess
import sys


def test_the_command_line_loads_without_torch_or_trimesh():
    code = (
        "import sys; from tognet.cli import app; "
        "print(sorted(m for m in ('torch', 'trimesh') if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def test_lazy_package_names_resolve_and_unknown_names_fail():
    import pytest

    import tognet.grasping as grasping
    import tognet.objects as objects

    assert callable(grasping.extract_crops) and callable(grasping.nms) and callable(grasping.cem)
    assert callable(objects.generate_set) and objects.ObjectRecord.__name__ == "ObjectRecord"
    assert "extract_crops" in dir(grasping) and "generate_set" in dir(objects)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = grasping.nope
    namespace: dict = {}
    exec("from tognet.grasping import *", namespace)  # noqa: S102  (the star import sees every name)
    assert "extract_crops" in namespace and "sample_antipodal" in namespace
