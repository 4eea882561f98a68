"""Packs the staged add-on package into the zip a user installs from Blender's preferences."""
import pathlib
import sys
import zipfile

src, dst = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
dst.parent.mkdir(parents=True, exist_ok=True)
with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as z:
    for path in sorted(src.rglob("*")):
        if path.is_file() and "__pycache__" not in path.parts and path.suffix != ".pyc":
            z.write(path, pathlib.Path(src.name) / path.relative_to(src))
