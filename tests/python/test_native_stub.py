"""addon/dgmesh/_native.pyi states the whole Python-C++ contract: every bound function, class,
field and parameter has a stub and every stub a binding (scripts/native_stub.py --check)."""

import importlib.util
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _tool():
    spec = importlib.util.spec_from_file_location("native_stub", ROOT / "scripts" / "native_stub.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_stub_matches_the_built_module():
    from dgmesh import _native

    tool = _tool()
    have = tool.shape((ROOT / "addon" / "dgmesh" / "_native.pyi").read_text(encoding="utf-8"))
    want = tool.shape(tool.stub(_native))
    assert sorted(set(want) - set(have)) == [], "bound but not in _native.pyi: run scripts/native_stub.py"
    assert sorted(set(have) - set(want)) == [], "in _native.pyi but not bound: run scripts/native_stub.py"
    assert want == have


def test_the_check_sees_a_missing_parameter():
    tool = _tool()
    assert tool.shape("def f(a, b) -> int: ...") != tool.shape("def f(a) -> int: ...")
    assert tool.shape("class A:\n    x: int\n") != tool.shape("class A:\n    y: int\n")
