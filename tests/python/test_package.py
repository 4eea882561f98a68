"""The package's metadata stays consistent and the plain-python face imports no bpy."""

import pathlib
import re
import subprocess
import sys

import dgmesh

PKG = pathlib.Path(dgmesh.__file__).parent


def test_versions_agree():
    manifest = (PKG / "blender_manifest.toml").read_text()
    m = re.search(r'^version = "([0-9.]+)"', manifest, re.M)
    assert m and m.group(1) == dgmesh.__version__
    assert ".".join(map(str, dgmesh.bl_info["version"])) == dgmesh.__version__
    assert dgmesh.bl_info["blender"] >= (3, 4, 0)


def test_manifest_permission_reasons_fit_blenders_limit():
    """`blender --command extension build/validate` refuses reasons over 64 characters."""
    manifest = (PKG / "blender_manifest.toml").read_text()
    section = manifest.split("[permissions]", 1)[1].split("\n[", 1)[0]
    reasons = re.findall(r'^\w+ = "([^"]*)"', section, re.M)
    assert reasons and all(len(r) <= 64 and not r.endswith(".") for r in reasons), reasons


def test_import_without_bpy():
    code = "import sys, dgmesh; assert 'bpy' not in sys.modules; print(dgmesh.__version__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={"PYTHONPATH": str(PKG.parent)})
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == dgmesh.__version__
