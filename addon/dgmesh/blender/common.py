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
    return True
