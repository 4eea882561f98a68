"""Every function and public method of the numpy API has type hints: each parameter (other than
*args / **kwargs) and the return. The API is what ``dgmesh.__all__`` names and the public names of
the modules it comes from (``dgmesh.fairing.subdivide_region``, ``dgmesh.core.as_vertices``, ...);
of classes, dgmesh's own Python classes (the bound C++ classes are typed in _native.pyi)."""

import inspect
import types

import pytest

import dgmesh
from dgmesh import core, crest, denoising, fairing, multires, remeshing, shapes, skeletal, unwrapping

MODULES = (core, denoising, crest, fairing, unwrapping, skeletal, multires, remeshing, shapes)


def _own(obj, module):
    return getattr(obj, "__module__", None) == module.__name__


def _public(module):
    """(qualified name, object) of the public functions and classes defined in ``module``."""
    for name, obj in vars(module).items():
        if not name.startswith("_") and (inspect.isfunction(obj) or inspect.isclass(obj)) and _own(obj, module):
            yield f"{module.__name__}.{name}", obj


def _methods(cls):
    """Public methods (plain, class and static; and getters written with def) of a Python class."""
    for name, attr in vars(cls).items():
        if name.startswith("_") and name != "__init__":
            continue
        if isinstance(attr, (classmethod, staticmethod)):
            attr = attr.__func__
        elif isinstance(attr, property):
            attr = attr.fget
            if attr is None or attr.__name__ == "<lambda>":  # generated accessors of bound fields
                continue
        if inspect.isfunction(attr):
            yield f"{cls.__module__}.{cls.__qualname__}.{name}", attr


def api():
    """Every function to check, by qualified name."""
    found = {}
    roots = [(name, getattr(dgmesh, name)) for name in dgmesh.__all__]
    for module in MODULES:
        roots += list(_public(module))
    for name, obj in roots:
        if isinstance(obj, types.ModuleType):
            roots += list(_public(obj))
        elif inspect.isfunction(obj):
            found[f"{obj.__module__}.{obj.__qualname__}"] = obj
        elif inspect.isclass(obj) and obj.__module__.startswith("dgmesh.") and obj.__module__ != "dgmesh._native":
            found.update(_methods(obj))
    return found


def missing_hints(fn):
    """Names of ``fn``'s parameters without an annotation, and "return" when that has none."""
    sig = inspect.signature(fn)
    params = list(sig.parameters.values())
    if params and params[0].name in ("self", "cls"):
        params = params[1:]
    missing = [p.name for p in params if p.annotation is inspect.Parameter.empty
               and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    if sig.return_annotation is inspect.Signature.empty:
        missing.append("return")
    return missing


def test_api_is_found():
    names = api()
    for expected in ("dgmesh.fairing.fair", "dgmesh.core.read_mesh", "dgmesh.shapes.icosphere",
                     "dgmesh.crest.CrestLines.filter", "dgmesh.skeletal.SkeletalRig.deform",
                     "dgmesh.multires.Multires.build", "dgmesh.multires.Multires.n_dense",
                     "dgmesh.crest.decimate_feature_defaults", "dgmesh.fairing.subdivide_region"):
        assert expected in names
    assert not any("_native" in n for n in names)


@pytest.mark.parametrize("name", sorted(api()))
def test_annotated(name):
    missing = missing_hints(api()[name])
    assert not missing, f"{name}: no type hint for {', '.join(missing)}"


def test_missing_hints_sees_gaps():
    def f(a, b: int, *args, c=1, **kw) -> None:
        pass

    def g(self, x: int):
        pass

    assert missing_hints(f) == ["a", "c"]
    assert missing_hints(g) == ["return"]
