"""Stored liquid states: the particle lattice and the arrays codec that keeps them.

The bounds are hand-checkable: snapping moves a coordinate by at most half its step
(2^-(e+1)), and the codec gives back the bytes it was given.
"""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

from app.core.liquid.particle_lattice import (
    ParticleLattice,
    morton_cells,
    morton_codes,
    particle_lattice,
    snap_state,
)
from app.core.liquid.scene import TILT_TANK_SPACINGS
from app.store.array_codec import (
    CorruptArrays,
    decode_arrays,
    encode_arrays,
    member_sizes,
    read_member_sizes,
)


def splashing_state(n: int = 2000, seed: int = 0) -> np.ndarray:
    """Particles in a 0.6 x 0.4 x 0.16 m tank with speeds up to 2 m/s."""
    rng = np.random.default_rng(seed)
    state = np.empty((n, 6), np.float32)
    state[:, :3] = rng.uniform(0, 1, (n, 3)) * np.array([0.6, 0.4, 0.16])
    state[:, 3:] = rng.normal(0, 0.7, (n, 3)).clip(-2, 2)
    return state


@pytest.mark.parametrize("preset", sorted(TILT_TANK_SPACINGS))
def test_the_position_step_is_a_power_of_two_at_most_a_200th_of_the_spacing(
    preset: str,
) -> None:
    spacing = TILT_TANK_SPACINGS[preset]
    lattice = particle_lattice(spacing)
    assert spacing / 400 < lattice.position_step <= spacing / 200
    assert lattice.velocity_step == 2.0**-8


def test_snapping_moves_each_value_by_at_most_half_a_step() -> None:
    lattice = ParticleLattice(position_exponent=14)
    state = splashing_state()
    snapped = snap_state(state, lattice)
    # the rows are permuted: compare each particle with its own snapped self
    order = np.argsort(morton_codes(np.rint(state[:, :3] * 2.0**14).astype(np.int64)))
    moved = np.abs(snapped - state[order])
    assert moved[:, :3].max() <= 2.0**-15 * (1 + 1e-6)
    assert moved[:, 3:].max() <= 2.0**-9 * (1 + 1e-6)
    assert np.all(np.diff(morton_codes(np.rint(snapped[:, :3] * 2.0**14).astype(np.int64))) >= 0)


def test_snapping_is_idempotent_bit_for_bit_and_has_no_negative_zeros() -> None:
    lattice = ParticleLattice(position_exponent=15)
    state = splashing_state()
    state[:10, 3:] = -1e-6  # rounds to -0.0 without care
    once = snap_state(state, lattice)
    assert once.view(np.uint32).tobytes() == snap_state(once, lattice).view(np.uint32).tobytes()
    assert not np.any(np.signbit(once) & (once == 0))


def test_morton_codes_interleave_the_bits_of_x_y_z() -> None:
    cells = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [3, 0, 0], [1, 1, 1]])
    assert morton_codes(cells).tolist() == [1, 2, 4, 9, 7]
    with pytest.raises(ValueError):
        morton_codes(np.array([[-1, 0, 0]]))


def test_a_snapped_state_decodes_to_itself_and_costs_far_less_than_float32() -> None:
    lattice = ParticleLattice(position_exponent=14)
    state = snap_state(splashing_state(20000), lattice)
    data = encode_arrays({"end_state": state})
    back = decode_arrays(data)["end_state"]
    assert back.dtype == np.float32 and back.tobytes() == state.tobytes()
    assert len(data) < 0.6 * state.nbytes


@pytest.mark.parametrize(
    "array",
    [
        np.random.default_rng(1).random(300),  # floats on no lattice: raw bytes
        np.array([-0.0, 0.5, 1.0], np.float32),  # a negative zero stays one
        np.tile(np.array([-0.0, 0.5, 1.0], np.float32), 400),  # ... in a large member too
        np.tile(np.array([0.25, -3.0, 1e-6]), (300, 1)),  # a lattice per column
        np.arange(3000, dtype=np.int16).reshape(30, 100) * 3 - 4000,
        np.arange(2000, dtype=np.uint8),  # wraps: 0..255 again and again
        np.arange(24, dtype=np.int8).reshape(2, 3, 4) - 12,
        np.array([0, 255, 3], np.uint8),
        np.array([2**64 - 1, 0], np.uint64),
        np.array([True, False]),
        np.float64(3.25),
        np.asarray(7, dtype=np.int64),
        np.zeros((0, 6), np.float32),
        np.array([np.nan, np.inf, 1.0]),
    ],
)
def test_the_codec_gives_back_any_numeric_array_exactly(array: np.ndarray) -> None:
    back = decode_arrays(encode_arrays({"a": array}))["a"]
    array = np.asarray(array)
    assert (back.dtype, back.shape) == (array.dtype, array.shape)
    assert back.tobytes() == array.tobytes()


def test_equal_arrays_give_equal_bytes_and_members_are_read_alone() -> None:
    arrays = {"b": np.arange(10), "a": np.ones((3, 4), np.int8)}
    data = encode_arrays(arrays)
    assert data == encode_arrays(dict(reversed(arrays.items())))
    assert list(decode_arrays(data, ["a"])) == ["a"]
    with pytest.raises(KeyError):
        decode_arrays(data, ["c"])


def test_the_codec_refuses_objects_and_foreign_bytes() -> None:
    with pytest.raises(ValueError, match="pickle"):
        encode_arrays({"a": np.array(["text"], dtype=object)})
    with pytest.raises(CorruptArrays):
        decode_arrays(b"PK\x03\x04 a zip")
    with pytest.raises(CorruptArrays):
        decode_arrays(encode_arrays({"a": np.arange(1000)})[:-5])


def _header(data: bytes) -> tuple[dict, int]:
    """The JSON header of arrays bytes and the offset where it ends."""
    start = len(b"SRGA1\n") + 4
    length = int.from_bytes(data[start - 4 : start], "little")
    return json.loads(data[start : start + length]), start + length


def test_a_field_smooth_along_its_last_axis_is_coded_as_last_axis_differences() -> None:
    rng = np.random.default_rng(3)
    slopes = rng.integers(-3, 4, (4, 30, 20, 1))
    field = (slopes * np.arange(40) + rng.integers(-100, 100, (4, 30, 20, 1))).astype(np.int16)
    data = encode_arrays({"sdf": field})
    (member,) = _header(data)[0]["members"]
    assert member["delta_axis"] == -1
    np.testing.assert_array_equal(decode_arrays(data)["sdf"], field)


def test_headers_from_before_the_last_axis_still_decode() -> None:
    """Bytes whose header says ``delta`` (first-axis differences) rather than ``delta_axis``."""
    frames = np.cumsum(np.random.default_rng(4).integers(-2, 3, (50, 400)), axis=0)
    data = encode_arrays({"frames": frames})
    head, end = _header(data)
    (member,) = head["members"]
    assert member["delta_axis"] == 0
    member["delta"] = True
    del member["delta_axis"]
    old = json.dumps(head).encode()
    rewritten = b"SRGA1\n" + len(old).to_bytes(4, "little") + old + data[end:]
    np.testing.assert_array_equal(decode_arrays(rewritten)["frames"], frames)


def test_a_state_in_morton_order_is_coded_as_gaps_along_the_curve() -> None:
    state = snap_state(splashing_state(), particle_lattice(0.01))
    data = encode_arrays({"end_state": state})
    (member,) = _header(data)[0]["members"]
    assert member.get("morton") is True
    assert decode_arrays(data)["end_state"].tobytes() == state.tobytes()
    shuffled = state[np.random.default_rng(5).permutation(len(state))]
    (member,) = _header(encode_arrays({"end_state": shuffled}))[0]["members"]
    assert "morton" not in member  # out of order: the codes would not be sorted


def test_morton_cells_undo_morton_codes() -> None:
    cells = np.random.default_rng(6).integers(0, 2**21, (5000, 3))
    np.testing.assert_array_equal(morton_cells(morton_codes(cells)), cells)


def test_member_sizes_can_be_read_from_the_header_alone() -> None:
    data = encode_arrays({"frames": np.arange(4000, dtype=np.int16), "state": np.ones((9, 6))})
    assert read_member_sizes(io.BytesIO(data)) == member_sizes(data)
    assert read_member_sizes(_OnlyHeader(data, _header(data)[1])) == member_sizes(data)
    buffer = io.BytesIO()
    np.savez(buffer, frames=np.zeros(3))
    assert read_member_sizes(io.BytesIO(buffer.getvalue())) is None  # an npz from before
    with pytest.raises(CorruptArrays):
        read_member_sizes(io.BytesIO(data[:8]))


class _OnlyHeader(io.BytesIO):
    """A stream that fails a read past ``end``: the payload must not be read."""

    def __init__(self, data: bytes, end: int) -> None:
        super().__init__(data)
        self.end = end

    def read(self, size: int | None = -1) -> bytes:
        if size is None or size < 0 or self.tell() + size > self.end:
            raise AssertionError("read past the header")
        return super().read(size)
