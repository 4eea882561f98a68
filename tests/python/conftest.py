import os
import pathlib
import sys

# The package lives in addon/; the build stages the compiled module into it. DGMESH_PACKAGE_DIR
# names another folder holding a dgmesh package instead (scripts/package_test.sh: the portable zip,
# unpacked).
sys.path.insert(0, os.environ.get("DGMESH_PACKAGE_DIR")
                or str(pathlib.Path(__file__).resolve().parents[2] / "addon"))
