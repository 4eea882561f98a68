"""Run the Blender test suite inside Blender.

    blender --background --factory-startup --python-exit-code 1 \
        --python tests/blender/run.py -- [pytest args]

The add-on is enabled the way a user would: a temporary scripts directory
with addons/dgmesh (a symlink to the repo's addon/dgmesh) is added to the
preferences' script directories, then addon_utils.enable().  --factory-startup
keeps the user's preferences untouched (they are neither read nor saved).
Exits with pytest's code; "no tests collected" (5) is an error like any
non-zero code.
"""

import shutil
import sys
import tempfile
from pathlib import Path

import addon_utils
import bpy

REPO = Path(__file__).resolve().parents[2]
TESTS = Path(__file__).resolve().parent


def _raise(exc):
    raise exc


def enable_addon():
    scripts = Path(tempfile.mkdtemp(prefix="dgmesh-scripts-"))
    (scripts / "addons").mkdir()
    (scripts / "addons" / "dgmesh").symlink_to(REPO / "addon" / "dgmesh", target_is_directory=True)
    filepaths = bpy.context.preferences.filepaths
    if hasattr(filepaths, "script_directories"):  # 3.6+: a list of script directories
        entry = filepaths.script_directories.new()
        entry.name = "dgmesh-tests"
        entry.directory = str(scripts)
    else:  # 3.4/3.5: a single directory
        filepaths.script_directory = str(scripts)
    bpy.utils.refresh_script_paths()  # puts <scripts>/addons on sys.path
    module = addon_utils.enable("dgmesh", default_set=True, handle_error=_raise)
    if module is None:
        raise RuntimeError("addon_utils.enable('dgmesh') failed")
    return scripts


def main(argv):
    import pytest

    try:
        scripts = enable_addon()
    except Exception as exc:  # e.g. the native module is not built
        print(f"run.py: could not enable the dgmesh add-on: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 3
    try:
        paths = [a for a in argv if not a.startswith("-") and Path(a.split("::")[0]).exists()]
        args = list(argv) if paths else [str(TESTS)] + list(argv)
        return int(pytest.main(["--rootdir", str(TESTS)] + args))
    finally:
        shutil.rmtree(scripts, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []))
