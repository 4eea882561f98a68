"""Small helpers every operator shares: which objects to act on, poll messages, report wording."""


def target_objects(context):
    """Mesh objects an operator acts on: the edited ones in Edit mode, the selected ones in Object
    mode; one object per mesh datablock (linked duplicates share their data)."""
    if context.mode == 'EDIT_MESH':
        objects = context.objects_in_mode_unique_data
    elif context.mode == 'OBJECT':
        objects = [o for o in context.selected_objects if o.type == 'MESH']
    else:
        return []
    seen, unique = set(), []
    for obj in objects:
        if obj.data.as_pointer() not in seen:
            seen.add(obj.data.as_pointer())
            unique.append(obj)
    return unique


def read_only_reason(obj):
    """Why the object's mesh cannot be changed, or None. Library data, and library overrides:
    Blender ignores foreach_set on an overridden mesh and a save drops what bmesh wrote to it."""
    mesh = obj.data
    if mesh.library is not None:
        return "mesh data is linked from a library and cannot be changed"
    if getattr(mesh, "override_library", None) is not None:
        return "mesh data is a library override and cannot be changed (make it local first)"
    return None


def _editable(coll):
    return coll.library is None and getattr(coll, "override_library", None) is None


def editable_collections(obj):
    """The collections of ``obj`` a new object may be linked into (Blender refuses linked and
    overridden ones)."""
    return [c for c in obj.users_collection if _editable(c)]


def editable_collection(context, obj):
    """Where a new object made for ``obj`` goes: a collection of ``obj`` in the current scene that is
    neither linked nor an override (the mesh may be in several scenes), else the scene's own."""
    root = context.scene.collection
    for coll in editable_collections(obj):
        if coll == root or coll in root.children_recursive:
            return coll
    return root


def shown_shape_notes(obj):
    """How the mesh an operator reads (the datablock's coordinates, in object space) differs from
    what the viewport shows, besides modifiers: a shape key mix, a non-uniform scale (Blender's own
    Unwrap says so too). Short phrases for a report."""
    notes = []
    keys = obj.data.shape_keys
    if keys is not None and len(keys.key_blocks) > 1:
        if not keys.use_relative:
            shown = True
        elif obj.mode == 'EDIT' or obj.show_only_shape_key:
            shown = obj.active_shape_key_index > 0  # the active key is what Edit mode shows
        else:
            shown = any(k.value != 0 and not k.mute for k in keys.key_blocks[1:])
        if shown:
            notes.append("measured on the basis shape, without its shape keys")
    scale = [abs(x) for x in obj.matrix_world.to_scale()]
    if min(scale) > 0 and max(scale) > (1 + 1e-4) * min(scale):
        notes.append("computed on the unscaled mesh (the object has non-uniform scale: apply it to work on "
                     "the shape as shown)")
    return notes


def report_shown_shape(op, objects):
    """One WARNING per note of :func:`shown_shape_notes`, naming the objects it applies to."""
    by_note = {}
    for obj in objects:
        for note in shown_shape_notes(obj):
            by_note.setdefault(note, []).append(obj.name)
    for note, names in by_note.items():
        more = f" and {len(names) - 3} more" if len(names) > 3 else ""
        op.report({'WARNING'}, f"{', '.join(map(repr, names[:3]))}{more}: {note}")


def poll_fail(cls, message):
    """Fails a poll with a reason the UI shows in the tooltip (Blender 3.0+)."""
    if hasattr(cls, "poll_message_set"):
        cls.poll_message_set(message)
    return False


def set_handlers(handlers, add=True):
    """Removes the app handlers ``handlers`` ((list name, function) pairs) and, with ``add``, appends
    them again: register/unregister stay idempotent. A handler counts as ours by name and module, so
    those of an earlier load of the module go too (a reload makes new functions) while another
    add-on's handlers of the same name stay."""
    import bpy

    for lst, fn in handlers:
        funcs = getattr(bpy.app.handlers, lst)
        for h in [h for h in funcs if getattr(h, "__name__", "") == fn.__name__
                  and getattr(h, "__module__", "") == fn.__module__]:
            funcs.remove(h)
    if add:
        for lst, fn in handlers:
            getattr(bpy.app.handlers, lst).append(fn)


def plural(n, word):
    return f"{n} {word}{'' if n == 1 else 's'}"


def poll_mesh_targets(cls, context, targets=target_objects):
    """The poll of operators that act on mesh objects in Object or mesh Edit mode."""
    if context.mode not in {'OBJECT', 'EDIT_MESH'}:
        return poll_fail(cls, "Only available in Object mode and mesh Edit mode")
    if not targets(context):
        return poll_fail(cls, "Select one or more mesh objects")
    return True


def poll_active_mesh(cls, context, edit_mode=False):
    """The poll of operators that act on the active mesh object, in Object mode (and mesh Edit
    mode when ``edit_mode``)."""
    modes = {'OBJECT', 'EDIT_MESH'} if edit_mode else {'OBJECT'}
    if context.mode not in modes:
        return poll_fail(cls, "Only available in Object mode and mesh Edit mode" if edit_mode
                         else "Only available in Object mode")
    obj = context.active_object
    if obj is None or obj.type != 'MESH':
        return poll_fail(cls, "The active object must be a mesh")
    # As Blender's own active-object operators: a hidden object stays active but is not edited.
    if context.mode == 'OBJECT' and not obj.visible_get():
        return poll_fail(cls, "The active object is hidden")
    return True


def enum_items(enum, labels):
    """EnumProperty items for a native enum (``_native.DenoiseMethod``, ...): the identifiers are
    the member names in upper case, in the enum's order. ``labels`` maps every member name to
    (label, description); a member missing or an unknown name raises ValueError at import."""
    names = list(enum.__members__)
    if set(labels) != set(names):
        raise ValueError(f"{enum.__name__}: labels for {sorted(labels)}, members are {names}")
    return tuple((name.upper(), *labels[name]) for name in names)


def enum_id(member):
    """The EnumProperty identifier of a native enum member."""
    return member.name.upper()
