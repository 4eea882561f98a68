"""Skeletal deformation data as text and files, without Blender: a rig's arrays as base64 text (the
.blend keeps a binding in a custom property of the mesh object), the checks of that saved state
(its schema, versioned) and deformed frames as a .pc2 point cache (Skeletal Bake)."""

import base64
import binascii
import io
import struct
import zipfile

import numpy as np

from .core import MeshError

SCHEMA_VERSION = 1  # the "schema" field of a binding; bindings saved before it have none (read as 0)


class BindDataError(MeshError):
    """Saved skeletal state (the binding's custom property or its bind data) that cannot be read."""


def _is_int(v):
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


def _is_number(v):
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _is_flag(v):
    return isinstance(v, (bool, int, np.integer))


def _list_of(check):
    return lambda v: isinstance(v, (list, tuple)) and all(check(x) for x in v)


_STR = (lambda v: isinstance(v, str), "a text")
_INT = (_is_int, "an integer")
_NUMBER = (_is_number, "a number")
_STRS = (_list_of(lambda v: isinstance(v, str)), "a list of texts")
_FLAGS = (_list_of(_is_flag), "a list of 0/1 values")
_NUMBERS = (_list_of(_is_number), "a list of numbers")

# Field -> (check, what it must be, required). Optional fields are absent from bindings saved by
# earlier versions (their readers supply the old defaults; the options' are OLD_OPTIONS).
INFO_FIELDS = {
    "schema": (*_INT, False), "id": (*_STR, True), "armature": (*_STR, True), "bones": (*_STRS, True),
    "data": (*_STR, True), "fairing_steps": (*_INT, True), "method": (*_STR, True),
    "modifiers": (*_STRS, True), "modifiers_viewport": (*_FLAGS, True), "modifiers_render": (*_FLAGS, True),
    "skeleton": (*_STR, True), "armature_tag": (*_STR, False), "armature_data": (*_STR, False),
    "bind_to_mesh": (*_NUMBERS, False), "bones_local": (*_NUMBERS, False), "bone_clearance": (*_NUMBER, False),
    "skeleton_blend": (*_STR, False), "control_faces": (*_INT, False), "target": (*_STR, False),
    "modifier": (*_STR, False), "node_group": (*_STR, False), "helper": (*_STR, False),
    "modifiers_object": (*_STRS, False), "rest_hash": (*_STR, False), "space": (*_NUMBERS, False),
    "created_basis": (_is_flag, "0 or 1", False), "untangle_iterations": (*_INT, False),
    "fold_guard": (*_INT, False), "contact_slide": (*_NUMBER, False),
    "follow_twist": (_is_flag, "0 or 1", False), "untangle_render": (*_INT, False),
    "integrate_skeleton": (_is_flag, "0 or 1", False), "ring_twist": (_is_flag, "0 or 1", False),
    "joint_fillet": (*_NUMBER, False),
}
_CHOICES = {"target": ("HELPER", "ATTRIBUTE", "SHAPE_KEY"), "skeleton_blend": ("DUAL_QUATERNION", "LINEAR")}

# Option field -> its value for bindings saved before the option existed: what those files were bound
# and deformed with, fixed here (not the library's defaults, which may change). Read by saved_options.
OLD_OPTIONS = {
    "bone_clearance": 0.95,  # files bound before the option: the library's fixed 0.95 then (today's default too)
    "untangle_iterations": 0,  # files bound before the option: no untangling existed (today's default too)
    "fold_guard": 0,  # files bound before the option: no fold guard existed (today's default: 50)
    "contact_slide": 0.0,  # files bound before the option: no joint contact (today's default too)
    "follow_twist": False,  # files bound before the option: the twist was not followed (today's default too)
    "integrate_skeleton": False,  # files bound before the option: the blend's skeleton (today's default: on)
    "ring_twist": False,  # files bound before the option: twists blended with the weights (today's default: on)
    "joint_fillet": 0.0,  # files bound before the option: no fillets (today's default: 2)
    "skeleton_blend": "LINEAR",  # files bound before the option: the linear blend (today's default: dual quaternion)
    "control_faces": 5000,  # files bound before it was stored: the library's 5000 then (today's default too)
}


def contact_slide_ok(value):
    """The joint contact's kappa as the library takes it (SkeletalDeformOptions::contact_slide): 0 (off)
    or a finite value of at least 1. Read by check_info and by Skeletal Bind before it binds."""
    return value == 0 or 1 <= value <= 1e6


def joint_fillet_ok(value):
    """The joint fillet's radius scale as the library takes it (SkeletalDeformOptions::joint_fillet): 0
    (off) or a positive finite value. Read by check_info and by Skeletal Bind before it binds."""
    return 0 <= value <= 1e6


def saved_options(info):
    """The options a binding was bound with, {field: value} for the fields of OLD_OPTIONS, each of
    its table value's type; a field the binding lacks (saved before the option) reads as the table's."""
    return {key: type(old)(info.get(key, old)) for key, old in OLD_OPTIONS.items()}


def render_untangle(info):
    """The untangling iterations of a binding's renders and bakes (Skeletal Bind's Untangle Creases
    Render): its stored ``untangle_render``; a binding saved before that field rendered with its one
    untangling setting, so it reads as ``untangle_iterations`` (as saved_options reads that)."""
    return int(info["untangle_render"] if "untangle_render" in info else saved_options(info)["untangle_iterations"])


def check_info(info, methods=()):
    """Checks a binding's saved fields (a plain dict, as ``IDPropertyGroup.to_dict()`` gives):
    schema version, types, lengths and choices. Raises BindDataError naming the first problem."""
    if not isinstance(info, dict):
        raise BindDataError(f"it is {type(info).__name__!s} {info!r:.40}, not the group of fields bind stores")
    version = info.get("schema", 0)
    if _is_int(version) and version > SCHEMA_VERSION:
        raise BindDataError(f"it was saved by a newer dgmesh (schema {version}; this one reads up to "
                            f"{SCHEMA_VERSION})")
    for key, (check, what, required) in INFO_FIELDS.items():
        if key not in info:
            if required:
                raise BindDataError(f"its field {key!r} is missing")
            continue
        if not check(info[key]):
            raise BindDataError(f"its field {key!r} must be {what}, not {info[key]!r:.40}")
    choices = dict(_CHOICES, **({"method": tuple(methods)} if methods else {}))
    for key, allowed in choices.items():
        if key in info and info[key] not in allowed:
            raise BindDataError(f"its field {key!r} is {info[key]!r:.40}, not one of {', '.join(allowed)}")
    n = len(info["modifiers"])
    for key in ("modifiers_viewport", "modifiers_render", "modifiers_object"):
        if key in info and len(info[key]) != n:
            raise BindDataError(f"its field {key!r} has {len(info[key])} entries, 'modifiers' {n}")
    sizes = {"bind_to_mesh": 16, "space": 16, "bones_local": 16 * len(info["bones"])}
    for key, size in sizes.items():
        if key in info and len(info[key]) != size:
            raise BindDataError(f"its field {key!r} has {len(info[key])} numbers, not {size}")
    if info["fairing_steps"] < 0:
        raise BindDataError(f"its field 'fairing_steps' is negative ({info['fairing_steps']})")
    for key in ("untangle_iterations", "fold_guard", "untangle_render"):
        if info.get(key, 0) < 0:
            raise BindDataError(f"its field {key!r} is negative ({info[key]})")
    if not contact_slide_ok(info.get("contact_slide", 0.0)):
        raise BindDataError(f"its field 'contact_slide' is {info['contact_slide']!r:.40}: 0 (off) or at least 1")
    if not joint_fillet_ok(info.get("joint_fillet", 0.0)):
        raise BindDataError(f"its field 'joint_fillet' is {info['joint_fillet']!r:.40}: 0 (off) or positive")
    if "control_faces" in info and info["control_faces"] < 1:
        raise BindDataError(f"its field 'control_faces' is {info['control_faces']}, not positive")


# Bind data array -> (dimensions, the fixed trailing ones (None: any)).
_ARRAYS = {"control_V": (2, (3,)), "control_F": (2, (3,)), "S": (2, (3,)), "weights": (2, (None,)),
           "bones_rest": (3, (4, 4))}


def check_arrays(arrays, n_bones=None):
    """Checks decoded bind data before the rig is rebuilt from it: the arrays every binding has,
    numeric, of their dimensions, as many skeletal vertices as control vertices and weight rows,
    one weight column and rest frame per bone (``n_bones``: the bones the binding names), and the
    stick skeleton (``bone_heads``, ``bone_tails``), when kept, one row of three per bone."""
    for key, (ndim, tail) in _ARRAYS.items():
        a = arrays.get(key)
        if a is None:
            raise BindDataError(f"its bind data has no array {key!r}")
        if a.dtype.kind not in "biuf" or a.ndim != ndim or any(t is not None and t != s
                                                                for t, s in zip(tail, a.shape[1:])):
            raise BindDataError(f"its bind data array {key!r} is {a.dtype} of shape {a.shape}")
    n = len(arrays["control_V"])
    if len(arrays["S"]) != n or len(arrays["weights"]) != n:
        raise BindDataError(f"its bind data arrays disagree: {n} control vertices, {len(arrays['S'])} skeletal "
                            f"vertices, {len(arrays['weights'])} weight rows")
    bones = {arrays["weights"].shape[1], len(arrays["bones_rest"])} | ({n_bones} if n_bones is not None else set())
    if len(bones) != 1:
        raise BindDataError(f"its bind data disagrees on the bone count ({sorted(bones)})")
    segments = [arrays.get(k) for k in ("bone_heads", "bone_tails")]  # absent in older data
    if any(a is not None for a in segments):
        B = len(arrays["bones_rest"])
        for key, a in zip(("bone_heads", "bone_tails"), segments):
            if a is None or a.dtype.kind not in "biuf" or a.shape != (B, 3):
                raise BindDataError(f"its bind data array {key!r} is "
                                    + ("missing" if a is None else f"{a.dtype} of shape {a.shape}")
                                    + f" (expected ({B}, 3), with the other)")


def encode_arrays(arrays):
    """Named arrays ({name: array}) as ASCII text (base64 of an .npz); :func:`decode_arrays` reads it."""
    # Uncompressed: deflate saved 15% of the text for 9x the time (1.3 s at 655K vertices); files
    # written with it still load (np.load reads both).
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def decode_arrays(text):
    """The named arrays {name: array} of :func:`encode_arrays`' text (compressed .npz text too).
    Raises BindDataError when the text is not such data (edited or cut short)."""
    damaged = BindDataError("its bind data text is damaged (not the base64 .npz archive bind stores)")
    try:
        raw = base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError, TypeError):
        raise damaged from None
    if not raw.startswith(b"PK"):  # np.load would try it as a pickle
        raise damaged
    try:
        with np.load(io.BytesIO(raw), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise BindDataError(f"its bind data is damaged ({type(exc).__name__}: {exc})") from None


def write_pc2(path, frames, start, rate=1.0):
    """Writes (nframes, n, 3) positions as a PC2 point cache."""
    frames = np.ascontiguousarray(frames, dtype=np.float32)
    with open(path, "wb") as f:
        f.write(struct.pack("<12siiffi", b"POINTCACHE2\0", 1, frames.shape[1], float(start), float(rate),
                            frames.shape[0]))
        f.write(frames.tobytes())
