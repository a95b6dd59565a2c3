"""Decoder of DySAQUASIMs particle frames, format versions 1 to 3.

The wire format is server/codec/FORMAT.md. This decoder gives the same floats, bit for bit, as
the C++ one (dysa::codec::FrameDecoder in server/codec/src/frame_decoder.cc) and follows the same
state machine: chunks of one frame are collected until the frame is complete, a delta frame is
predicted from up to three frames since the last keyframe, and after a lost chunk, a corrupt
chunk or a late join the decoder waits for the next keyframe.

Example::

    decoder = FrameDecoder()
    for chunk in stream:
        frame = decoder.add_chunk(chunk)
        if frame is not None:
            draw(frame.positions)
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence, Tuple

import numpy as np
import zstandard

from . import detail as _detail

__all__ = [
    "DecodeError",
    "FIELD_DENSITY",
    "FIELD_POSITIONS",
    "FIELD_SPEED",
    "FIELD_VELOCITY",
    "FORMAT_VERSION",
    "Frame",
    "VELOCITY_COMPONENTS",
    "VELOCITY_OCTAHEDRAL",
    "FrameDecoder",
]

MAGIC = 0x46535944  # "DYSF"
FORMAT_VERSION = 4  # the newest version this decoder reads; it reads every older one too
HEADER_SIZE = 152

_KEYFRAME_FLAG = 1
_OCTAHEDRAL_FLAG = 2  # version 2 and later
_IDS_FLAG = 4  # version 4: explicit ids (FORMAT.md, "Ids")

# Frame.velocity_encoding values.
VELOCITY_COMPONENTS = "components"
VELOCITY_OCTAHEDRAL = "octahedral"

FIELD_POSITIONS = 1
FIELD_SPEED = 2
FIELD_VELOCITY = 4
FIELD_DENSITY = 8

# Components in payload order (FORMAT.md).
_POS_X, _POS_Y, _POS_Z, _SPEED, _VEL_X, _VEL_Y, _VEL_Z, _DENSITY = range(8)
_COMPONENTS = 8

# A decoder never allocates more than this many particles, whatever a header claims.
_MAX_COUNT = 20_000_000  # particles a frame holds at most, as in the C++ decoder
_MAX_IDS = 500_000_000  # ids a subset by rank may name (the solver's limit), as in the C++ one

# std::numeric_limits<float>::epsilon().
_FLOAT_EPSILON = 2.0**-23

# The chunk header, FORMAT.md's table in order.
_HEADER = struct.Struct("<IHHIIQdHHIIIBBBBI3d3dddddIIII")
assert _HEADER.size == HEADER_SIZE

_ZSTD_MAGIC = 0xFD2FB528
_ZSTD_SKIPPABLE_MASK = 0xFFFFFFF0
_ZSTD_SKIPPABLE_START = 0x184D2A50


class DecodeError(Exception):
    """Malformed, truncated or hostile input, or a newer format version.

    After it the decoder waits for the next keyframe where the stream cannot go on.
    """


@dataclass(eq=False)
class Frame:
    """The decoded content of a frame, in id order of the kept particles: `ids` (k * stride, or
    the particles a detail threshold keeps, dysa.detail).

    Arrays are numpy float32. Fields absent from the stream are None. The errors are the
    largest possible |decoded - original| of each field, from the header's ranges and bits
    (0 for an absent field).
    """

    frame_seq: int
    step: int
    time: float
    keyframe: bool
    count: int
    stride: int
    fields: int
    positions: np.ndarray
    speed: Optional[np.ndarray] = None
    velocities: Optional[np.ndarray] = None
    densities: Optional[np.ndarray] = None
    velocity_encoding: str = VELOCITY_COMPONENTS
    position_error: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    speed_error: float = 0.0
    velocity_error: float = 0.0
    density_error: float = 0.0
    detail_threshold: int = 0  # 0: every stride-th particle; else a subset by rank (dysa.detail)
    ids: Optional[np.ndarray] = None  # uint32, each particle's id
    explicit_ids: bool = False  # the ids came with the frame (version 4): any subset

    @property
    def detail_fraction(self) -> float:
        """The fraction of the (stride's) particles the frame holds: 1 without a threshold."""
        return _detail.detail_fraction(self.detail_threshold)


def _str(value: float) -> str:
    """Formats a double like C++'s ostream with its default settings."""
    return "%g" % value


def _levels(bits: int) -> int:
    """L = 2^bits - 1, the largest quantised value."""
    return 0xFFFFFFFF if bits >= 32 else (1 << bits) - 1


def _error_bound(lo: float, hi: float, bits: int) -> float:
    """Half a quantisation step plus float rounding: of the decoded value, and of the speed,
    which the encoder rounds to float before it quantises it."""
    half_step = 0.5 * (hi - lo) / float(_levels(bits))
    magnitude = max(abs(lo), abs(hi))
    return half_step + magnitude * _FLOAT_EPSILON


def _octahedral_error_bound(velocity_max: float, bits: int) -> float:
    """The bound on each component of an octahedral velocity (derived in FORMAT.md and beside
    OctahedralErrorBound in server/codec/src/octahedral_velocity.cc)."""
    levels = float(_levels(bits))
    return velocity_max * ((0.5 + 6.0 * math.sqrt(2.0)) / levels + 8 * _FLOAT_EPSILON)


def _from_octahedral(magnitude: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Velocities (m, 3) float32 from |v| and the octahedral coordinates (u, v), all float64:
    the same IEEE double operations in the same order as FromOctahedral in C++."""
    au, av = np.abs(u), np.abs(v)
    z = 1.0 - au - av
    folded = z < 0
    sign_u = np.where(u >= 0, 1.0, -1.0)
    sign_v = np.where(v >= 0, 1.0, -1.0)
    u = np.where(folded, (1.0 - av) * sign_u, u)
    v = np.where(folded, (1.0 - au) * sign_v, v)
    scale = magnitude / np.sqrt(u * u + v * v + z * z)
    return np.stack([u * scale, v * scale, z * scale], axis=1).astype(np.float32)


class _Header:
    """A parsed chunk header."""

    __slots__ = (
        "version", "flags", "frame_seq", "count", "step", "time", "chunk_index", "chunk_count",
        "first", "chunk_particles", "fields", "position_bits", "speed_bits", "velocity_bits",
        "density_bits", "stride", "position_min", "position_max", "speed_max", "velocity_max",
        "density_min", "density_max", "raw_size", "payload_size", "bits_size", "detail_threshold",
    )

    def __init__(self, values: tuple) -> None:
        (_, self.version, self.flags, self.frame_seq, self.count, self.step, self.time,
         self.chunk_index, self.chunk_count, self.first, self.chunk_particles, self.fields,
         self.position_bits, self.speed_bits, self.velocity_bits, self.density_bits,
         self.stride) = values[:17]
        self.position_min = values[17:20]
        self.position_max = values[20:23]
        (self.speed_max, self.velocity_max, self.density_min, self.density_max,
         self.raw_size, self.payload_size, self.bits_size, self.detail_threshold) = values[23:31]

    @property
    def keyframe(self) -> bool:
        """Whether the frame is a keyframe (decodes without earlier frames)."""
        return (self.flags & _KEYFRAME_FLAG) != 0

    @property
    def octahedral(self) -> bool:
        """Whether velocity is sent as |v| and two octahedral coordinates."""
        return (self.flags & _OCTAHEDRAL_FLAG) != 0

    @property
    def explicit_ids(self) -> bool:
        """Whether the frame's particles are named by ids the stream sends (version 4)."""
        return (self.flags & _IDS_FLAG) != 0

    @property
    def ids_in_payload(self) -> bool:
        """Whether the payload carries the chunk's ids after the components: keyframes with
        explicit ids."""
        return self.explicit_ids and self.keyframe

    def has(self, c: int) -> bool:
        """Whether component c is in the payload."""
        if c <= _POS_Z:
            return True
        if c == _SPEED:
            return (self.fields & FIELD_SPEED) != 0
        if c == _DENSITY:
            return (self.fields & FIELD_DENSITY) != 0
        return (self.fields & FIELD_VELOCITY) != 0

    def bits(self, c: int) -> int:
        """Bit width of component c."""
        if c <= _POS_Z:
            return self.position_bits
        if c == _SPEED:
            return self.speed_bits
        if c == _DENSITY:
            return self.density_bits
        return self.velocity_bits

    def lo(self, c: int) -> float:
        """Lower end of component c's range."""
        if c <= _POS_Z:
            return self.position_min[c]
        if c == _SPEED:
            return 0.0
        if c == _DENSITY:
            return self.density_min
        if self.octahedral:
            return 0.0 if c == _VEL_X else -1.0  # |v|, then the two coordinates
        return -self.velocity_max

    def hi(self, c: int) -> float:
        """Upper end of component c's range."""
        if c <= _POS_Z:
            return self.position_max[c]
        if c == _SPEED:
            return self.speed_max
        if c == _DENSITY:
            return self.density_max
        if self.octahedral:
            return self.velocity_max if c == _VEL_X else 1.0
        return self.velocity_max

    def component_count(self) -> int:
        """Components in the payload."""
        return sum(1 for c in range(_COMPONENTS) if self.has(c))

    def same_layout(self, o: "_Header") -> bool:
        """Same stream layout: what a delta frame must share with its reference frame.

        Floats compare with ==, so a NaN never matches (as in C++).
        """
        return (self.count == o.count and self.stride == o.stride and self.fields == o.fields
                and self.detail_threshold == o.detail_threshold
                and self.explicit_ids == o.explicit_ids
                and self.octahedral == o.octahedral
                and self.position_bits == o.position_bits and self.speed_bits == o.speed_bits
                and self.velocity_bits == o.velocity_bits
                and self.density_bits == o.density_bits
                and all(a == b for a, b in zip(self.position_min, o.position_min))
                and all(a == b for a, b in zip(self.position_max, o.position_max))
                and self.speed_max == o.speed_max and self.velocity_max == o.velocity_max
                and self.density_min == o.density_min and self.density_max == o.density_max)


def _read_header(chunk: bytes) -> _Header:
    """Parses and checks everything in a header that does not depend on other chunks."""
    if len(chunk) < HEADER_SIZE:
        raise DecodeError("truncated chunk: %d bytes, the header alone is %d"
                          % (len(chunk), HEADER_SIZE))
    values = _HEADER.unpack_from(chunk)
    if values[0] != MAGIC:
        raise DecodeError("not a DySAQUASIMs frame (bad magic)")
    h = _Header(values)
    if h.version < 1 or h.version > FORMAT_VERSION:
        relation = "is newer than" if h.version > FORMAT_VERSION else "is not supported by"
        raise DecodeError("frame format version %d %s this decoder (version %d); update the "
                          "client" % (h.version, relation, FORMAT_VERSION))
    if h.version < 3 and h.detail_threshold != 0:
        raise DecodeError("corrupt frame header: reserved bytes set")

    def fail(what: str) -> None:
        raise DecodeError("corrupt frame header: " + what)

    if h.version >= 4:
        known_flags = _KEYFRAME_FLAG | _OCTAHEDRAL_FLAG | _IDS_FLAG
    elif h.version >= 2:
        known_flags = _KEYFRAME_FLAG | _OCTAHEDRAL_FLAG
    else:
        known_flags = _KEYFRAME_FLAG
    if (h.flags & ~known_flags) != 0:
        fail("unknown flags %d for version %d" % (h.flags, h.version))
    if h.octahedral and not (h.fields & FIELD_VELOCITY):
        fail("octahedral flag without velocity")
    if not (h.fields & FIELD_POSITIONS) or (h.fields & ~0xF) != 0:
        fail("fields %d (positions must be present, bits 0-3 only)" % h.fields)
    if h.count > _MAX_COUNT:
        fail("count %d over the limit" % h.count)
    if h.stride == 0:
        fail("stride 0")
    if h.chunk_count == 0 or h.chunk_index >= h.chunk_count:
        fail("chunk index out of range")
    if h.first + h.chunk_particles > h.count:
        fail("chunk particles out of range")
    if h.count > 0 and h.chunk_particles == 0:
        fail("empty chunk")
    if h.chunk_particles > 0 and not math.isfinite(h.time):
        fail("time is not finite")
    for c in range(_COMPONENTS):
        bits = h.bits(c)
        max_bits = 24 if c <= _POS_Z else 16
        if not h.has(c):
            # The three velocity components share one bit width: checked once.
            if bits != 0 and c != _VEL_Y and c != _VEL_Z:
                fail("bits set for an absent field")
            continue
        if bits < 1 or bits > max_bits:
            fail("bit width %d" % bits)
        lo, hi = h.lo(c), h.hi(c)
        if not math.isfinite(lo) or not math.isfinite(hi) or not hi > lo or not math.isfinite(hi - lo):
            fail("range [%s, %s]" % (_str(lo), _str(hi)))
    if HEADER_SIZE + h.payload_size + h.bits_size != len(chunk):
        raise DecodeError("truncated or oversized chunk: header says %d payload bytes, %d "
                          "present" % (h.payload_size + h.bits_size, len(chunk) - HEADER_SIZE))
    return h


def _zstd_frame_end(data: bytes, start: int) -> Optional[int]:
    """End of the zstd frame at data[start:] (as ZSTD_findFrameCompressedSize), None if it is
    not a whole zstd frame."""
    if len(data) - start < 5 or int.from_bytes(data[start:start + 4], "little") != _ZSTD_MAGIC:
        return None
    try:
        at = start + zstandard.frame_header_size(data[start:start + 18])
    except zstandard.ZstdError:
        return None
    checksum = (data[start + 4] & 4) != 0
    while True:
        if at + 3 > len(data):
            return None
        block = int.from_bytes(data[at:at + 3], "little")
        last, kind, size = block & 1, (block >> 1) & 3, block >> 3
        if kind == 3:
            return None
        at += 3 + (1 if kind == 1 else size)
        if last:
            break
    if checksum:
        at += 4
    return at if at <= len(data) else None


def _decompress(payload: bytes, raw_size: int) -> Optional[bytes]:
    """The payload decompressed to exactly raw_size bytes, or None.

    The caller has checked that the first zstd frame declares raw_size bytes. Like the C++
    decoder (ZSTD_decompressDCtx), the payload may go on with skippable frames; anything else
    after the first frame is refused (C++ would also take zstd frames of no content there).
    """
    try:
        raw = zstandard.ZstdDecompressor().decompress(payload, max_output_size=raw_size)
    except zstandard.ZstdError:
        return None
    if len(raw) != raw_size:
        return None
    at = _zstd_frame_end(payload, 0)
    if at is None:
        return None
    while at < len(payload):
        if len(payload) - at < 8:
            return None
        magic = int.from_bytes(payload[at:at + 4], "little")
        if (magic & _ZSTD_SKIPPABLE_MASK) != _ZSTD_SKIPPABLE_START:
            return None
        at += 8 + int.from_bytes(payload[at + 4:at + 8], "little")
        if at > len(payload):
            return None
    return raw


class FrameDecoder:
    """Decodes a stream of chunks into frames (the C++ dysa::codec::FrameDecoder).

    One decoder per stream: delta frames are predicted from the frames decoded before.

    Two differences from the C++ decoder, on malformed input only: when add_chunks refuses a
    chunk as a duplicate or as not matching its frame, none of the chunks of that frame in the
    same call are marked received (C++ marks the ones before it without decoding them), and
    particles no chunk covers are 0 (C++ may leave values of an earlier frame there).
    """

    def __init__(self) -> None:
        # The frame being assembled from its chunks.
        self._pending_seq: Optional[int] = None
        self._pending_header: Optional[_Header] = None  # its first chunk's header
        self._received: List[bool] = []  # per chunk
        self._chunk_size = 0  # the pending frame's chunk size (all but the last chunk)
        self._pending: Optional[Frame] = None
        self._current: List[Optional[np.ndarray]] = []  # its quantised values, per component
        # The last complete frame's header, and the quantised values of up to 3 frames since
        # the last keyframe, newest first (delta frames are predicted from them).
        self._previous_header: Optional[_Header] = None
        self._history: List[List[Optional[np.ndarray]]] = []
        self._have_previous = False
        self._ids: Optional[np.ndarray] = None  # the last explicit-id keyframe's ids

    @property
    def waiting_for_keyframe(self) -> bool:
        """True while a delta frame cannot be decoded (no keyframe yet, or a frame was missed)."""
        return not self._have_previous

    def add_chunk(self, data: bytes) -> Optional[Frame]:
        """Adds one chunk; returns the frame once all its chunks have arrived, else None.

        Raises DecodeError with a clear message for malformed, truncated or hostile input and
        for a newer format version.
        """
        return self.add_chunks([data])

    def add_chunks(self, chunks: Iterable[bytes]) -> Optional[Frame]:
        """Adds chunks in order (typically all chunks of one frame); returns the last frame
        they complete, else None. A frame left incomplete when the next one starts is dropped.
        """
        chunks = [c if isinstance(c, bytes) else bytes(c) for c in chunks]
        # Every header is checked before anything changes.
        headers = [_read_header(c) for c in chunks]
        done: Optional[Frame] = None
        begin = 0
        while begin < len(chunks):
            h = headers[begin]
            if self._pending_seq != h.frame_seq:
                if self._pending_seq is not None:
                    self._have_previous = False  # the incomplete frame is lost
                self._pending_seq = None
                if not h.keyframe and not self._reference_ok(h):
                    self._have_previous = False  # wait for a keyframe
                    begin += 1
                    continue
                self._start_frame(h)
            end = self._take_group(headers, begin)
            self._decode_group(chunks, headers, begin, end)
            begin = end
            if all(self._received):
                done = self._complete()
        return done

    def _reference_ok(self, h: _Header) -> bool:
        """Whether delta frame h can be decoded against the last complete frame."""
        if not self._have_previous:
            return False
        previous = self._previous_header
        return previous.frame_seq + 1 == h.frame_seq and previous.same_layout(h)

    def _start_frame(self, h: _Header) -> None:
        """Makes h's frame the pending one, with zeroed arrays."""
        n = h.count
        self._pending_seq = h.frame_seq
        self._pending_header = h
        self._received = [False] * h.chunk_count
        self._chunk_size = 0
        self._pending = Frame(
            frame_seq=h.frame_seq, step=h.step, time=h.time, keyframe=h.keyframe, count=n,
            stride=h.stride, fields=h.fields, positions=np.zeros((n, 3), np.float32),
            speed=np.zeros(n, np.float32) if h.fields & FIELD_SPEED else None,
            velocities=np.zeros((n, 3), np.float32) if h.fields & FIELD_VELOCITY else None,
            densities=np.zeros(n, np.float32) if h.fields & FIELD_DENSITY else None,
            velocity_encoding=VELOCITY_OCTAHEDRAL if h.octahedral else VELOCITY_COMPONENTS)
        self._current = [np.zeros(n, np.uint32) if h.has(c) else None
                         for c in range(_COMPONENTS)]
        if h.ids_in_payload:
            self._pending.ids = np.zeros(n, np.uint32)

    def _check_chunk_range(self, h: _Header) -> None:
        """The encoder's layout: chunk i covers particles [i P, min((i + 1) P, count)) for one
        chunk size P per frame, so the chunks of a frame cover it exactly once."""
        last = h.chunk_index + 1 == h.chunk_count
        m = h.chunk_particles
        ok = h.first + m == h.count if last else m > 0
        size = 0
        if not last:
            size = m
        elif h.chunk_index > 0:
            ok = ok and h.first % h.chunk_index == 0
            size = h.first // h.chunk_index
        if size != 0:
            ok = ok and size * h.chunk_index == h.first and self._chunk_size in (0, size)
            ok = ok and (not last or m <= size)
        else:
            ok = ok and h.first == 0
        if not ok:
            raise DecodeError("chunk %d of frame %d covers particles [%d, %d), which does not fit "
                              "the frame's other chunks"
                              % (h.chunk_index, h.frame_seq, h.first, h.first + m))
        if size != 0:
            self._chunk_size = size

    def _take_group(self, headers: Sequence[_Header], begin: int) -> int:
        """Checks the consecutive chunks of the pending frame from `begin` and marks them
        received; returns the end of the group. Nothing is marked if one of them is refused."""
        first = self._pending_header
        end = begin
        seen = set()
        while end < len(headers) and headers[end].frame_seq == first.frame_seq:
            hc = headers[end]
            self._check_chunk_range(hc)
            if (hc.flags != first.flags or hc.count != first.count or hc.step != first.step
                    or hc.chunk_count != first.chunk_count or not hc.same_layout(first)
                    or not hc.time == first.time):
                raise DecodeError("chunk %d does not match the other chunks of frame %d"
                                  % (hc.chunk_index, hc.frame_seq))
            if self._received[hc.chunk_index] or hc.chunk_index in seen:
                raise DecodeError("chunk %d of frame %d received twice"
                                  % (hc.chunk_index, hc.frame_seq))
            seen.add(hc.chunk_index)
            end += 1
        for index in seen:
            self._received[index] = True
        return end

    def _decode_group(self, chunks: Sequence[bytes], headers: Sequence[_Header], begin: int,
                      end: int) -> None:
        """Decodes chunks[begin:end] into the pending frame; on a corrupt one the frame is
        dropped and the decoder waits for a keyframe."""
        for k in range(begin, end):
            h = headers[k]
            payload_end = HEADER_SIZE + h.payload_size
            error = self._decode_body(h, chunks[k][HEADER_SIZE:payload_end],
                                      chunks[k][payload_end:payload_end + h.bits_size])
            if error is not None:
                self._pending_seq = None
                self._have_previous = False
                raise DecodeError("corrupt chunk %d of frame %d: %s"
                                  % (h.chunk_index, self._pending_header.frame_seq, error))

    def _decode_body(self, h: _Header, payload: bytes, bits: bytes) -> Optional[str]:
        """Decodes one chunk into the pending frame; returns an error message, or None on
        success."""
        n = h.component_count() + (1 if h.ids_in_payload else 0)
        m = h.chunk_particles
        try:
            content = zstandard.frame_content_size(payload)
        except zstandard.ZstdError:
            content = None
        if content != h.raw_size:
            return "payload size does not match the header"
        # At most two bytes and 4 planes per component.
        if h.raw_size > n * (2 + 4 * m):
            return "raw size too large"
        raw = _decompress(payload, h.raw_size)
        if raw is None:
            return "payload does not decompress"
        if len(raw) < 2 * n:
            return "payload too short"
        raw = np.frombuffer(raw, np.uint8)
        splits = [int(v) for v in raw[0:2 * n:2]]
        planes = [int(v) for v in raw[1:2 * n:2]]
        expected = 2 * n
        expected_bits = 0
        for split, count in zip(splits, planes):
            if split > 24:
                return "split beyond 24 bits"
            if count > 4:
                return "more than 4 byte planes"
            expected += count * m
            expected_bits += (m * split + 7) // 8
        if expected != len(raw):
            return "payload size does not match its byte planes"
        if expected_bits != len(bits):
            return "packed bits do not match their split"
        packed = np.frombuffer(bits, np.uint8)

        frame = self._pending
        at = 2 * n
        bit_at = 0
        slot = 0
        first, last = h.first, h.first + m
        for c in range(_COMPONENTS):
            if not h.has(c):
                continue
            split, count = splits[slot], planes[slot]
            slot += 1
            levels = _levels(h.bits(c))
            if split + 8 * count > 32:
                return "residual wider than 32 bits"
            z = self._residuals(raw[at:at + count * m], count,
                                packed[bit_at:bit_at + (m * split + 7) // 8], split, m)
            at += count * m
            bit_at += (m * split + 7) // 8
            residual = (z >> 1) ^ -(z & 1)  # zig-zag, in [-2^31, 2^31 - 1]
            if h.keyframe:
                value = np.cumsum(residual)  # the chunk's first particle is predicted as 0
            else:
                value = self._prediction(c, first, last, levels) + residual
            if m > 0 and (value.min() < 0 or value.max() > levels):
                return "decoded value outside its range"
            self._current[c][first:last] = value
            if h.octahedral and _VEL_X <= c <= _VEL_Z:
                continue  # needs all three: below

            lo = h.lo(c)
            step = (h.hi(c) - lo) / float(levels)
            with np.errstate(over="ignore"):  # huge ranges round to inf, as in C++
                decoded = (lo + value.astype(np.float64) * step).astype(np.float32)
            if c <= _POS_Z:
                frame.positions[first:last, c] = decoded
            elif c == _SPEED:
                frame.speed[first:last] = decoded
            elif c == _DENSITY:
                frame.densities[first:last] = decoded
            else:
                frame.velocities[first:last, c - _VEL_X] = decoded
        if h.octahedral and m > 0:
            levels = float(_levels(h.velocity_bits))
            q = [self._current[c][first:last].astype(np.float64) for c in (_VEL_X, _VEL_Y, _VEL_Z)]
            frame.velocities[first:last] = _from_octahedral(
                0.0 + q[0] * (h.velocity_max / levels), -1.0 + q[1] * (2.0 / levels),
                -1.0 + q[2] * (2.0 / levels))
        if h.ids_in_payload:
            # The first id, then each gap minus one (FORMAT.md, "Ids").
            split, count = splits[slot], planes[slot]
            if split + 8 * count > 32:
                return "residual wider than 32 bits"
            z = self._residuals(raw[at:at + count * m], count,
                                packed[bit_at:bit_at + (m * split + 7) // 8], split, m)
            ids = np.cumsum(z + 1) - 1
            if m > 0 and ids[-1] >= _MAX_IDS:
                return "particle id over the limit"
            frame.ids[first:last] = ids
        return None

    @staticmethod
    def _residuals(planes: np.ndarray, count: int, packed: np.ndarray, split: int,
                   m: int) -> np.ndarray:
        """z = (high << split) | low of m particles as int64: high from `count` byte planes
        (least significant first), low from the little-endian bit stream `packed`."""
        words = np.zeros((m, 4), np.uint8)
        words[:, :count] = planes.reshape(count, m).T
        z = words.view("<u4").reshape(m).astype(np.int64) << split
        if split > 0:
            stream = np.unpackbits(packed, bitorder="little")[:m * split].reshape(m, split)
            low_bits = np.zeros((m, 32), np.uint8)
            low_bits[:, :split] = stream
            low = np.packbits(low_bits, axis=1, bitorder="little").view("<u4").reshape(m)
            z |= low.astype(np.int64)
        return z

    def _prediction(self, c: int, first: int, last: int, levels: int) -> np.ndarray:
        """The prediction of component c of particles first .. last - 1 of a delta frame from
        the frames since the last keyframe (FORMAT.md), as int64."""
        a = self._history[0][c][first:last].astype(np.int64)
        if len(self._history) == 1:
            return a
        b = self._history[1][c][first:last].astype(np.int64)
        if len(self._history) == 2:
            return np.clip(2 * a - b, 0, levels)
        c3 = self._history[2][c][first:last].astype(np.int64)
        return np.clip(3 * (a - b) + c3, 0, levels)

    def _complete(self) -> Frame:
        """Finishes the pending frame: it becomes the reference of the next delta frame."""
        first = self._pending_header
        frame = self._pending
        frame.detail_threshold = first.detail_threshold
        frame.explicit_ids = first.explicit_ids
        if first.explicit_ids:
            if first.keyframe:
                if frame.count > 1 and not np.all(np.diff(frame.ids.astype(np.int64)) > 0):
                    self._have_previous = False
                    self._pending_seq = None
                    self._pending = None
                    raise DecodeError("corrupt frame %d: particle ids do not increase"
                                      % first.frame_seq)
                self._ids = frame.ids.copy()
            else:
                frame.ids = self._ids.copy()  # a delta frame has its reference's particles
        else:
            try:
                frame.ids = _detail.kept_ids(first.count, first.stride, first.detail_threshold,
                                             _MAX_IDS)
            except ValueError as e:
                self._have_previous = False
                self._pending_seq = None
                self._pending = None
                raise DecodeError("corrupt frame header: " + str(e)) from None
        frame.position_error = tuple(
            _error_bound(first.position_min[a], first.position_max[a], first.position_bits)
            for a in range(3))
        if first.fields & FIELD_SPEED:
            frame.speed_error = _error_bound(0.0, first.speed_max, first.speed_bits)
        if first.fields & FIELD_VELOCITY:
            if first.octahedral:
                frame.velocity_error = _octahedral_error_bound(first.velocity_max,
                                                               first.velocity_bits)
            else:
                frame.velocity_error = _error_bound(-first.velocity_max, first.velocity_max,
                                                    first.velocity_bits)
        if first.fields & FIELD_DENSITY:
            frame.density_error = _error_bound(first.density_min, first.density_max,
                                               first.density_bits)
        if first.keyframe:
            self._history = []
        self._history.insert(0, self._current)
        del self._history[3:]
        self._current = []
        self._previous_header = first
        self._have_previous = True
        self._pending_seq = None
        self._pending = None
        return frame

