"""The artifact format of named arrays: integer coding, delta, byte planes, zstd.

Bundles are mostly integers: int8 SDF and uint8 occupancy frames, and liquid states whose
float32 values lie on a power-of-two lattice (``app.core.liquid.particle_lattice``). Each member
is coded on its own, losslessly:

1. integers as they are; floats as integers ``x * 2^e`` with the least exponent ``e``
   per column (last axis) that makes every value an integer, when there is one below
   ``MAX_EXPONENT``; any other float array as its raw bytes;
2. integers zigzag-coded, either as they are or as differences along the first axis
   (time for frames, the Morton order for particles) or the last (neighbouring voxels of
   a column of an SDF), in C order or with the first axis last (a voxel's frames, a
   column's particles, side by side), and split into byte planes (all low bytes, then
   the next...), so the constant high bytes of small numbers compress to nothing; of
   these five and the raw bytes, the one a fast zstd level compresses smallest is kept
   (members of at most ``SMALL_MEMBER_BYTES`` are raw bytes);
3. each member's bytes are one zstd frame, so a reader of the occupancy decompresses no
   SDF.

Every coding is checked by decoding it before it is kept, so what is read back is the
array that was written, bit for bit (the signs of zeros included). The bytes are a
function of the arrays alone (sorted members, single-threaded zstd at a fixed level),
so equal arrays give equal bytes and hence the same content hash.

Layout: ``MAGIC``, a little-endian uint32 header length, the header (JSON: per member its
name, dtype, shape, coding and compressed length), then the members' zstd frames in the
header's order. A header's ``delta_axis`` is 0, -1 or null; headers written before the
last axis was tried say ``delta`` (true for the first axis).

Artifacts written before this format are ``.npz`` zip files
(:func:`app.store.artifacts.ArtifactStore.get_arrays` tells them apart by their first
bytes).
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterable, Mapping
from typing import Any, BinaryIO

import numpy as np
import zstandard

from app.core.liquid.particle_lattice import MORTON_BITS, morton_cells, morton_codes

ARRAYS_MEDIA_TYPE = "application/x-srg-arrays+zstd"
MAGIC = b"SRGA1\n"
#: zstd level: on the `tiny` liquid's clip records 5.5 ms of CPU a member set against 19.7
#: at level 16, for 3.9 % more bytes; level 16's compression was a quarter of an
#: experiment's growth (docs/runtime.md, "Where an experiment's time goes")
ZSTD_LEVEL = 9
#: the fast zstd level that picks a member's coding before it is compressed at ZSTD_LEVEL
SELECTION_LEVEL = 3
#: members this small are stored as raw bytes: trying codings would cost more than it saves
SMALL_MEMBER_BYTES = 512
#: floats needing more fractional bits than this are stored as raw bytes
MAX_EXPONENT = 30
_HEADER_LENGTH = struct.Struct("<I")


class CorruptArrays(ValueError):
    """Bytes that are not an arrays artifact, or one cut short."""


def encode_arrays(arrays: Mapping[str, np.ndarray]) -> bytes:
    """Deterministic compressed bytes of named numeric arrays (see the module docstring)."""
    compressor = zstandard.ZstdCompressor(level=ZSTD_LEVEL, threads=0)
    trial = zstandard.ZstdCompressor(level=SELECTION_LEVEL, threads=0)
    members: list[dict[str, Any]] = []
    payloads: list[bytes] = []
    for name in sorted(arrays):
        header, payload = _encode_member(np.asarray(arrays[name]), compressor, trial)
        members.append({"name": name, **header, "length": len(payload)})
        payloads.append(payload)
    head = json.dumps({"members": members}, sort_keys=True, separators=(",", ":")).encode()
    return b"".join([MAGIC, _HEADER_LENGTH.pack(len(head)), head, *payloads])


def decode_arrays(data: bytes, names: Iterable[str] | None = None) -> dict[str, np.ndarray]:
    """The arrays of :func:`encode_arrays` bytes; with ``names``, only those members."""
    located = _members(data)
    decompressor = zstandard.ZstdDecompressor()
    out = {}
    for name in located if names is None else names:
        if name not in located:
            raise KeyError(f"{name} is not a member of the arrays artifact")
        member, at = located[name]
        payload = data[at : at + member["length"]]
        if len(payload) != member["length"]:
            raise CorruptArrays(f"arrays artifact cut short in member {name}")
        out[name] = _decode_member(member, decompressor.decompress(payload))
    return out


def member_sizes(data: bytes) -> dict[str, int]:
    """The compressed bytes of each member of :func:`encode_arrays` bytes (header aside)."""
    return {name: member["length"] for name, (member, _) in _members(data).items()}


def read_member_sizes(stream: BinaryIO) -> dict[str, int] | None:
    """:func:`member_sizes` of the artifact in ``stream``, reading its header alone; None
    if it holds no arrays artifact (an ``.npz`` from before the codec)."""
    fixed = stream.read(len(MAGIC) + _HEADER_LENGTH.size)
    if not fixed.startswith(MAGIC):
        return None
    if len(fixed) < len(MAGIC) + _HEADER_LENGTH.size:
        raise CorruptArrays("arrays artifact cut short in its header")
    (head_length,) = _HEADER_LENGTH.unpack_from(fixed, len(MAGIC))
    return member_sizes(fixed + stream.read(head_length))


def _members(data: bytes) -> dict[str, tuple[dict[str, Any], int]]:
    """Each member's header and the offset of its zstd frame, by name."""
    if not data.startswith(MAGIC):
        raise CorruptArrays("not an arrays artifact (bad magic)")
    start = len(MAGIC) + _HEADER_LENGTH.size
    try:
        (head_length,) = _HEADER_LENGTH.unpack_from(data, len(MAGIC))
        members = json.loads(data[start : start + head_length])["members"]
    except (struct.error, ValueError, KeyError) as exc:
        raise CorruptArrays(f"unreadable arrays header: {exc}") from None
    offset = start + head_length
    located = {}
    for member in members:
        located[member["name"]] = (member, offset)
        offset += member["length"]
    return located


# ---- one member --------------------------------------------------------------------
def _encode_member(
    array: np.ndarray, compressor: zstandard.ZstdCompressor, trial: zstandard.ZstdCompressor
) -> tuple[dict[str, Any], bytes]:
    if array.dtype.kind not in "biuf":
        raise ValueError(f"arrays artifacts hold numbers only (never a pickle), not {array.dtype}")
    array = np.asarray(array, order="C")
    base = {"dtype": array.dtype.str, "shape": list(array.shape)}
    raw = ({**base, "coding": "bytes"}, _byte_planes(array))
    if array.nbytes <= SMALL_MEMBER_BYTES:
        return raw[0], compressor.compress(raw[1])
    ints, exponents = _as_integers(array)
    candidates: list[tuple[dict[str, Any], bytes]] = []
    if ints is not None:
        for delta_axis, first_last in _integer_codings(array.ndim):
            width, planes = _integer_planes(ints, delta_axis=delta_axis, first_last=first_last)
            header: dict[str, Any] = {**base, "coding": "ints", "exponents": exponents}
            header.update(delta_axis=delta_axis, first_last=first_last, width=width)
            candidates.append((header, planes))
        if (cells := _morton_columns(ints, exponents)) is not None:
            morton, exponents = cells
            width, planes = _integer_planes(morton, delta_axis=0, first_last=True)
            header = {**base, "coding": "ints", "exponents": exponents, "morton": True}
            header.update(delta_axis=0, first_last=True, width=width)
            candidates.append((header, planes))
    candidates.append(raw)
    if len(candidates) > 1:  # the fast level ranks the codings as the slow one does
        candidates.sort(key=lambda candidate: len(trial.compress(candidate[1])))
    header, planes = candidates[0]
    payload = compressor.compress(planes)
    back = _decode_member(header, zstandard.ZstdDecompressor().decompress(payload))
    if back.tobytes() != array.tobytes():  # never expected: keep the bytes, not a doubt
        header, payload = raw[0], compressor.compress(raw[1])
    return header, payload


def _decode_member(member: Mapping[str, Any], raw: bytes) -> np.ndarray:
    dtype, shape = np.dtype(member["dtype"]), tuple(member["shape"])
    if member["coding"] == "bytes":
        planes = np.frombuffer(raw, np.uint8).reshape(dtype.itemsize, -1)
        return planes.T.copy().view(dtype).reshape(shape)
    morton = member.get("morton", False)
    coded = (shape[0], shape[1] - 2) if morton else shape
    count = int(np.prod(coded, dtype=np.int64))
    width = member["width"]
    planes = np.frombuffer(raw, np.uint8).reshape(width, count)
    wide = np.zeros((count, 8), np.uint8)
    wide[:, :width] = planes.T
    zigzag = wide.view("<u8").reshape(-1)
    ints = (zigzag >> np.uint64(1)).astype(np.int64) ^ -(zigzag & np.uint64(1)).astype(np.int64)
    moved = coded[1:] + coded[:1] if member["first_last"] else coded
    ints = ints.reshape(moved)
    if member["first_last"]:
        ints = np.moveaxis(ints, -1, 0)
    delta_axis = member.get("delta_axis", 0 if member.get("delta") else None)
    if delta_axis is not None:
        ints = np.cumsum(ints, axis=delta_axis)
    if morton:
        ints = np.concatenate([morton_cells(ints[:, 0].astype(np.uint64)), ints[:, 1:]], axis=1)
    exponents = member["exponents"]
    if exponents is None:
        return ints.astype(dtype).reshape(shape)
    return np.ldexp(ints.astype(np.float64), -np.asarray(exponents)).astype(dtype)


def _as_integers(array: np.ndarray) -> tuple[np.ndarray | None, list[int] | None]:
    """The array as int64, and for floats the exponent of each column; None if lossy."""
    if array.dtype.kind in "biu":
        if array.dtype == np.uint64 and array.size and array.max() >= 2**63:
            return None, None
        return array.astype(np.int64), None
    if array.ndim == 0 or array.size == 0:
        return None, None
    wide = array.astype(np.float64)
    if not np.all(np.isfinite(wide)):
        return None, None
    columns = wide.reshape(-1, array.shape[-1] if array.ndim > 1 else 1)
    needed = _fraction_bits(columns).max(axis=0)
    if needed.max() > MAX_EXPONENT or np.abs(columns).max() * 2.0 ** needed.max() >= 2**52:
        return None, None
    exponents = needed.tolist()
    ints = np.rint(np.ldexp(wide, needed)).astype(np.int64)
    back = np.ldexp(ints.astype(np.float64), -needed).astype(array.dtype)
    if back.tobytes() != array.tobytes():  # e.g. negative zeros: keep the exact bytes
        return None, None
    return ints, exponents


def _morton_columns(
    ints: np.ndarray, exponents: list[int] | None
) -> tuple[np.ndarray, list[int]] | None:
    """A particle state's first three columns as one column of Morton codes, or None.

    Applies to (n, >= 3) floats whose rows are in Morton order of their first three
    columns, non-negative cells on one lattice (``app.core.liquid.particle_lattice``): the
    codes' differences are the gaps between neighbours along the curve, fewer bits than
    three coordinates' differences. Each position column is brought to the finest of
    their exponents; the exponents returned are those the decoded columns are scaled by.
    """
    if exponents is None or ints.ndim != 2 or ints.shape[1] < 3 or len(ints) < 2:
        return None
    finest = max(exponents[:3])
    cells = ints[:, :3] << (finest - np.asarray(exponents[:3]))
    if cells.min() < 0 or cells.max() >= 1 << MORTON_BITS:
        return None
    codes = morton_codes(cells)
    if codes.max() >= 2**62 or np.any(codes[1:] < codes[:-1]):
        return None
    morton = np.concatenate([codes.astype(np.int64)[:, None], ints[:, 3:]], axis=1)
    return morton, [finest] * 3 + exponents[3:]


def _fraction_bits(values: np.ndarray) -> np.ndarray:
    """The fractional binary digits of each finite float64 (0 for integers and zeros).

    ``x = m 2^p`` with the 53-bit integer mantissa ``M = m 2^53``; its trailing zeros
    ``t`` leave ``53 - p - t`` digits after the binary point.
    """
    mantissa, power = np.frexp(values)
    digits = np.ldexp(np.abs(mantissa), 53).astype(np.int64)
    lowest = digits & -digits  # the lowest set bit, a power of two (0 for zeros)
    trailing = np.log2(np.maximum(lowest, 1)).astype(np.int64)
    return np.where(values == 0, 0, np.maximum(53 - power - trailing, 0))


def _integer_codings(ndim: int) -> list[tuple[int | None, bool]]:
    """The (delta_axis, first_last) codings worth trying on ``ndim`` axes, plain first.

    With one axis, moving it changes nothing and the last axis is the first; differences
    along the last axis with the first moved last would repeat the first-axis ones.
    """
    if ndim == 0:
        return [(None, False)]
    if ndim == 1:
        return [(None, False), (0, False)]
    return [(None, False), (None, True), (0, False), (0, True), (-1, False)]


def _integer_planes(
    ints: np.ndarray, *, delta_axis: int | None, first_last: bool
) -> tuple[int, bytes]:
    """Zigzag-coded ``ints`` (differences along ``delta_axis`` unless None) as planes."""
    if delta_axis is not None:
        ints = np.diff(ints, axis=delta_axis, prepend=np.zeros_like(ints.take([0], delta_axis)))
    if first_last:
        ints = np.moveaxis(ints, 0, -1)
    flat = np.ascontiguousarray(ints).reshape(-1)
    zigzag = ((flat << 1) ^ (flat >> 63)).astype(np.uint64)
    top = int(zigzag.max()) if zigzag.size else 0
    width = max(1, (top.bit_length() + 7) // 8)
    planes = zigzag.view(np.uint8).reshape(-1, 8)[:, :width]
    return width, planes.T.tobytes()


def _byte_planes(array: np.ndarray) -> bytes:
    return array.reshape(-1).view(np.uint8).reshape(-1, array.dtype.itemsize).T.tobytes()
