"""Blender side of dgmesh: everything that imports bpy lives in this package.

register()/unregister() are called by the add-on's top-level register()/
unregister().  Both are idempotent, so register -> unregister -> register (and
a repeated register, e.g. on script reload) work.
"""

import bpy

from . import (
    bridge,
    ops_crest,
    ops_curvature,
    ops_denoise,
    ops_fair,
    ops_multires,
    ops_remesh,
    ops_skeletal,
    ops_unwrap,
    prefs,
    ui,
)

# Registration order: preferences, operators (one module per capability), then the UI.
_MODULES = (prefs, ops_curvature, ops_denoise, ops_fair, ops_crest, ops_unwrap, ops_multires, ops_skeletal, ops_remesh, ui)


def _classes():
    for module in _MODULES:
        yield from module.classes


def register():
    for cls in _classes():
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)
        bpy.utils.register_class(cls)
    ui.register_menus()
    prefs.apply_thread_count()


def unregister():
    ui.unregister_menus()
    for cls in reversed(list(_classes())):
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)


__all__ = ["bridge", "prefs", "ui", "register", "unregister"]
