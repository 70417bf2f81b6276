"""Small files that would cost thousands of times their size in memory are refused from their headers before
anything is read (issue 79): an npz recording's members, a stored scene's meta at an output d2sr checks."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

from d2sr.atomic import made_by_d2sr
from d2sr.errors import InputError
from d2sr.frames import open_frames


def _npz(path, **members: bytes | np.ndarray) -> None:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for name, value in members.items():
            if isinstance(value, np.ndarray):
                buf = io.BytesIO()
                np.lib.format.write_array(buf, value, allow_pickle=False)
                value = buf.getvalue()
            z.writestr(f"{name}.npy", value)


def _declared(shape: str, descr: str = "<U100000") -> bytes:
    """An .npy header declaring ``shape`` with no data behind it."""
    head = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}"
    head += " " * (63 - (len(head) + 10) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + len(head).to_bytes(2, "little") + head.encode()


DEPTH = np.full((2, 48, 64), 2000, np.uint16)


@pytest.mark.parametrize(
    ("member", "value"),
    [
        ("names", np.array(["a" * 50_000, "b"])),  # 2 names, 400 kB each as numpy stores them
        ("names", _declared("(2,)", "<U10000000")),  # names of ten million characters
        ("timestamps_ns", _declared("(10000000000000,)", "<i8")),  # terabytes declared
        ("intrinsics", np.array("x" * 100_000)),
        ("depth_scale", _declared("(1000, 1000)", "<f8")),
    ],
)
def test_an_npz_member_larger_than_its_frames_need_is_refused_before_it_is_read(tmp_path, member, value):
    path = tmp_path / "rec.npz"
    _npz(path, depth=DEPTH, **{member: value})
    with pytest.raises(InputError, match=member):
        open_frames(path)


@pytest.mark.parametrize("shape", ["(" * 30_000 + ")" * 30_000, "(" + "9" * 5000 + ",)"])
def test_a_header_numpy_cannot_parse_is_one_line(tmp_path, shape):
    path = tmp_path / "rec.npz"
    _npz(path, depth=_declared(shape, "<u2"))
    with pytest.raises(InputError):
        open_frames(path)


def test_a_scene_s_oversized_meta_at_an_output_is_not_read(tmp_path):
    path = tmp_path / "scene.npz"
    _npz(path, meta=np.frombuffer(b'{"format": "d2sr scene"}' + b" " * 600_000, np.uint8))
    assert not made_by_d2sr(path)
    _npz(path, meta=np.frombuffer(b'{"format": "d2sr scene 1"}', np.uint8))
    assert made_by_d2sr(path)
