import pathlib
import sys

# The package lives in addon/; the build stages the compiled module into it.
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "addon"))
