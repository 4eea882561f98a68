"""dgmesh.skeletal_data: bind data as text, deformed frames as a .pc2 point cache (no Blender)."""

import base64
import io
import struct

import numpy as np

from dgmesh.skeletal_data import (INFO_FIELDS, OLD_OPTIONS, check_info, decode_arrays, encode_arrays,
                                  saved_options, write_pc2)


def test_bind_data_encoding_reads_earlier_compressed_files():
    """Bind data is stored uncompressed now (deflate cost 1.3 s at 655K vertices for 15% less
    text); files bound by earlier versions hold savez_compressed data, which must still load."""
    arrays = {"a": np.arange(10.0), "b": np.eye(3, dtype=np.int32)}
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    for text in (encode_arrays(arrays), base64.b64encode(buf.getvalue()).decode("ascii")):
        back = decode_arrays(text)
        assert set(back) == {"a", "b"} and all(np.array_equal(back[k], arrays[k]) for k in arrays)
        assert back["b"].dtype == np.int32
    assert encode_arrays(arrays).isascii()


def test_pc2_header_and_frames(tmp_path):
    """The PC2 layout Blender's Mesh Cache reads: a 32-byte header (signature, version, points,
    start frame, sample rate, frame count) and float32 positions frame after frame."""
    frames = np.arange(2 * 4 * 3, dtype=float).reshape(2, 4, 3) / 7
    path = tmp_path / "x.pc2"
    write_pc2(path, frames, start=5, rate=0.5)
    data = path.read_bytes()
    assert len(data) == 32 + frames.size * 4
    assert struct.unpack("<12siiffi", data[:32]) == (b"POINTCACHE2\0", 1, 4, 5.0, 0.5, 2)
    assert np.array_equal(np.frombuffer(data[32:], "<f4").reshape(2, 4, 3), frames.astype(np.float32))


def _info(**fields):
    """A binding's saved fields as the first versions stored them (no option fields), plus ``fields``."""
    return dict(id="x", armature="Armature", bones=["Upper", "Lower"], data="", fairing_steps=2,
                method="VARIATIONAL", modifiers=[], modifiers_viewport=[], modifiers_render=[], skeleton="s",
                **fields)


def test_options_of_bindings_saved_before_them_come_from_the_one_table():
    """A binding saved before its options existed reads each missing one as OLD_OPTIONS' value (the
    table the live update and Rebind read, tests/blender/test_skeletal.py), typed as the table's;
    one that has them keeps its own. The table's values are valid saved state themselves."""
    check_info(_info())
    assert saved_options(_info()) == OLD_OPTIONS
    assert all(type(v) is type(OLD_OPTIONS[k]) for k, v in saved_options(_info()).items())
    own = dict(bone_clearance=0.5, untangle_iterations=np.int64(3), fold_guard=20, contact_slide=3.0, follow_twist=1,
               integrate_skeleton=1, ring_twist=1, joint_fillet=1.5, skeleton_blend="DUAL_QUATERNION",
               control_faces=800)
    assert set(own) == set(OLD_OPTIONS)
    check_info(_info(**own))
    got = saved_options(_info(**own))
    assert got == own and got["follow_twist"] is True and got["integrate_skeleton"] is True and got["ring_twist"] is True
    assert type(got["untangle_iterations"]) is int
    for key, old in OLD_OPTIONS.items():
        check, what, required = INFO_FIELDS[key]
        assert not required and check(old), key
        assert saved_options(_info(**{k: v for k, v in own.items() if k != key})) == dict(own, **{key: old})


def test_render_untangling_is_its_own_field_or_the_one_setting_saved_before_it():
    """Untangle Creases Render: a binding's own untangle_render; one saved before the field rendered
    with its one untangling setting (saved_options' untangle_iterations, OLD_OPTIONS' when that is
    missing too). Negative or non-integer values are named."""
    import pytest
    from dgmesh.skeletal_data import BindDataError, render_untangle
    assert render_untangle(_info(untangle_iterations=3, untangle_render=7)) == 7
    assert render_untangle(_info(untangle_iterations=3)) == 3
    assert render_untangle(_info()) == OLD_OPTIONS["untangle_iterations"]
    check_info(_info(untangle_render=0))
    for bad in (-1, 2.5, "10"):
        with pytest.raises(BindDataError, match="untangle_render"):
            check_info(_info(untangle_render=bad))


def test_joint_contact_must_be_off_or_at_least_one():
    """contact_slide as the library takes it: 0 (off) or a finite kappa >= 1; anything else is named."""
    import pytest
    from dgmesh.skeletal_data import BindDataError
    for ok in (0, 0.0, 1, 3.0):
        check_info(_info(contact_slide=ok))
    for bad in (0.5, -1.0, float("nan"), float("inf")):
        with pytest.raises(BindDataError, match="contact_slide"):
            check_info(_info(contact_slide=bad))


def test_joint_fillet_must_be_off_or_positive():
    """joint_fillet as the library takes it: 0 (off) or a finite positive radius scale; anything else
    is named."""
    import pytest
    from dgmesh.skeletal_data import BindDataError
    for ok in (0, 0.0, 0.5, 2.0):
        check_info(_info(joint_fillet=ok))
    for bad in (-0.5, float("nan"), float("inf")):
        with pytest.raises(BindDataError, match="joint_fillet"):
            check_info(_info(joint_fillet=bad))


def test_stored_stick_skeleton_is_checked_and_may_be_absent():
    """Bind data keeps the bones' segments (bone_heads, bone_tails) since they define the stick
    skeleton; data saved before has none and passes; a half-kept or misshapen pair is refused by
    name before the rig is rebuilt."""
    import pytest

    from dgmesh.skeletal_data import BindDataError, check_arrays
    base = {"control_V": np.zeros((4, 3)), "control_F": np.zeros((4, 3), np.int32), "S": np.zeros((4, 3)),
            "weights": np.ones((4, 2)) / 2, "bones_rest": np.repeat(np.eye(4)[None], 2, 0)}
    check_arrays(base, 2)
    check_arrays(dict(base, bone_heads=np.zeros((2, 3)), bone_tails=np.ones((2, 3))), 2)
    for bad, word in (({"bone_heads": np.zeros((2, 3))}, "'bone_tails' is missing"),
                      ({"bone_heads": np.zeros((3, 3)), "bone_tails": np.ones((2, 3))}, r"'bone_heads' is float64 of shape \(3, 3\)"),
                      ({"bone_heads": np.zeros((2, 3)), "bone_tails": np.array([["a"] * 3] * 2)}, "'bone_tails' is <U1")):
        with pytest.raises(BindDataError, match=word):
            check_arrays(dict(base, **bad), 2)
