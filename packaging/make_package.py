"""Packs the portable add-on: the Python package from addon/dgmesh plus the compiled modules and
libraries from the portable build, into two zips:

  dgmesh-<version>-linux-x64.zip         Blender 4.2+ extension, laid out as `blender --command
                                         extension build` does: blender_manifest.toml at the root
  dgmesh-<version>-linux-x64-legacy.zip  Blender 3.4-4.1 add-on: everything under a top folder dgmesh/

usage: make_package.py ADDON_DIR NATIVE_DIR OUT_DIR PLATFORM
"""
import pathlib
import re
import sys
import zipfile

addon, native, out = (pathlib.Path(a) for a in sys.argv[1:4])
platform = sys.argv[4]
version = re.search(r'^__version__ = "([0-9.]+)"', (addon / "__init__.py").read_text(), re.M).group(1)

# The developer build stages its own module and libdgmesh into addon/dgmesh: never ship those.
DEV_BUILD = re.compile(r"^(_native\..*\.(so|pyd)|libdgmesh\.so.*)$")
files = {}
for path in sorted(addon.rglob("*")):
    rel = path.relative_to(addon)
    if path.is_file() and "__pycache__" not in rel.parts and path.suffix != ".pyc" \
            and not DEV_BUILD.match(rel.name):
        files[rel.as_posix()] = path
for path in sorted(native.iterdir()):
    if path.is_file():
        files[path.name] = path
assert "blender_manifest.toml" in files and any(n.startswith("_native.") for n in files), files

# The manifest names the one platform this zip's compiled modules are for.
manifest = re.sub(r'^platforms = .*$', f'platforms = ["{platform}"]',
                  files["blender_manifest.toml"].read_text(), count=1, flags=re.M)
assert f'platforms = ["{platform}"]' in manifest

out.mkdir(parents=True, exist_ok=True)
for name, prefix in ((f"dgmesh-{version}-{platform}.zip", ""),
                     (f"dgmesh-{version}-{platform}-legacy.zip", "dgmesh/")):
    with zipfile.ZipFile(out / name, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
        for rel, path in files.items():
            info = zipfile.ZipInfo.from_file(path, prefix + rel)
            info.compress_type = zipfile.ZIP_DEFLATED
            data = manifest.encode() if rel == "blender_manifest.toml" else path.read_bytes()
            z.writestr(info, data, compresslevel=9)
    print(out / name)
