"""Add-on preferences: the native library's thread count."""

import sys

import bpy
from bpy.props import IntProperty

# The add-on's top-level package: "dgmesh" as a legacy add-on; for a 4.2+
# extension it is "bl_ext.<repo>.dgmesh". AddonPreferences.bl_idname must be it.
ADDON_PACKAGE = __package__.rpartition(".")[0]


def api():
    """The add-on package (its public numpy API), looked up at call time."""
    return sys.modules[ADDON_PACKAGE]


def get_prefs(context=None):
    """This add-on's preferences, or None if the add-on is not in the user's
    add-on list (e.g. imported as a plain package, or during first enable)."""
    context = context or bpy.context
    addon = context.preferences.addons.get(ADDON_PACKAGE)
    return addon.preferences if addon is not None else None


def apply_thread_count(context=None):
    """Pass the stored thread count to the native library (0 = all cores)."""
    prefs = get_prefs(context)
    if prefs is not None:
        api().set_num_threads(int(prefs.num_threads))


def _on_threads_changed(self, context):
    api().set_num_threads(int(self.num_threads))


class DGMeshPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_PACKAGE

    num_threads: IntProperty(
        name="Threads",
        description="Worker threads used by the native geometry library (0 = all cores)",
        default=0,
        min=0,
        soft_max=64,
        update=_on_threads_changed,
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "num_threads")
        layout.label(text=f"dgmesh {getattr(api(), '__version__', '?')}")


classes = (DGMeshPreferences,)
