"""Blender side of dgmesh: everything that imports bpy lives in this package.

register()/unregister() are called by the add-on's top-level register()/
unregister().  Both are idempotent, so register -> unregister -> register (and
a repeated register, e.g. on script reload) work.
"""

import bpy

from . import (
    bridge,
    ops_auto_unwrap,
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

from .common import set_handlers

# Registration order: preferences, operators (one module per capability), then the UI.
_MODULES = (prefs, ops_curvature, ops_denoise, ops_fair, ops_crest, ops_unwrap, ops_auto_unwrap, ops_multires, ops_skeletal, ops_remesh, ui)


def _classes():
    for module in _MODULES:
        yield from module.classes


# Custom properties pointing from an object we made (crest-line curve, multires control cage) to
# its source object. An ID pointer follows renames but is a user: a deleted source stayed in the
# file, in no scene, kept alive by it.
_SOURCE_KEYS = (ops_crest.CURVE_KEY, ops_multires.CONTROL_KEY)
_scene_counts = []


def release_deleted_sources(force=False):
    """Drops the pointers to source objects that are in no scene any more (deleted), so Blender
    frees them like any deleted object; the curves and cages stay. Cheap unless a scene lost objects."""
    counts = [len(s.objects) for s in bpy.data.scenes]
    if not force and counts == _scene_counts:
        return
    _scene_counts[:] = counts
    for o in bpy.data.objects:
        if o.library is not None:
            continue
        for key in _SOURCE_KEYS:
            src = o.get(key)
            if isinstance(src, bpy.types.Object) and not src.users_scene:
                del o[key]


@bpy.app.handlers.persistent
def _on_depsgraph(*_args):
    release_deleted_sources()


@bpy.app.handlers.persistent
def _on_file(*_args):
    release_deleted_sources(force=True)


_HANDLERS = (("depsgraph_update_post", _on_depsgraph), ("save_pre", _on_file), ("load_post", _on_file))


def register():
    for cls in _classes():
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)
        bpy.utils.register_class(cls)
    ui.register_menus()
    prefs.apply_thread_count()
    set_handlers(_HANDLERS)


def unregister():
    set_handlers(_HANDLERS, add=False)
    ui.unregister_menus()
    for cls in reversed(list(_classes())):
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)


__all__ = ["bridge", "prefs", "ui", "register", "unregister"]
