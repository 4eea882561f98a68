"""dgmesh.skeletal_data: bind data as text, deformed frames as a .pc2 point cache (no Blender)."""

import base64
import io
import struct

import numpy as np

from dgmesh.skeletal_data import decode_arrays, encode_arrays, write_pc2


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
