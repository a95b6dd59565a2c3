"""Tests of the Python frame decoder (clients/python/dysa/codec.py) against the C++ one.

write_codec_vectors (tests/codec/write_codec_vectors.cc) encodes synthetic frames with the C++
FrameEncoder and decodes them with the C++ FrameDecoder; every frame the Python decoder makes of
the same chunks must be identical, bit for bit. The negative tests check the state machine:
refused chunks, lost frames, late joins and recovery on the next keyframe.

Run: /usr/bin/python3 tests/python/test_codec.py [PATH/TO/write_codec_vectors] [unittest args]
(the writer's path may also come from the environment variable DYSA_CODEC_VECTORS).
"""

import json
import os
import struct
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import numpy as np
import zstandard

# Run by hand without PYTHONPATH: the package next to this repository's tests.
_CLIENT = str(Path(__file__).resolve().parents[2] / "clients" / "python")
if _CLIENT not in sys.path:
    sys.path.append(_CLIENT)

from dysa import codec, detail  # noqa: E402
from dysa.codec import DecodeError, FrameDecoder  # noqa: E402

_vectors = None  # the written vectors, set by setUpModule


class _Vectors:
    """The vector writer's output: a temporary directory and its manifest."""

    def __init__(self, writer: str) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="dysa_codec_vectors_")
        self.root = Path(self._dir.name)
        subprocess.run([writer, str(self.root)], check=True)
        with open(self.root / "manifest.json", encoding="utf-8") as f:
            manifest = json.load(f)
        self.scenarios = {s["name"]: s for s in manifest["scenarios"]}
        for scenario in manifest["scenarios"]:
            for frame in scenario["frames"]:
                frame["chunk_bytes"] = [(self.root / c).read_bytes() for c in frame["chunks"]]

    def frames(self, name: str) -> list:
        """The frames of scenario `name`, in stream order."""
        return self.scenarios[name]["frames"]

    def array(self, file) -> np.ndarray:
        """A decoded array the C++ decoder wrote (raw little-endian float32)."""
        return np.fromfile(self.root / file, dtype="<f4")

    def close(self) -> None:
        """Removes the directory."""
        self._dir.cleanup()


def setUpModule():  # noqa: N802 (unittest's name)
    global _vectors
    writer = os.environ.get("DYSA_CODEC_VECTORS")
    if not writer:
        raise RuntimeError("the path of write_codec_vectors is needed: pass it as the first "
                           "argument or in DYSA_CODEC_VECTORS")
    _vectors = _Vectors(writer)


def tearDownModule():  # noqa: N802
    if _vectors is not None:
        _vectors.close()


def _with_header(chunk: bytes, offset: int, fmt: str, value) -> bytes:
    """The chunk with one header field replaced."""
    out = bytearray(chunk)
    struct.pack_into("<" + fmt, out, offset, value)
    return bytes(out)


def _parts(chunk: bytes):
    """The chunk's zstd payload, packed low bits and raw (decompressed) size."""
    raw_size, payload_size, bits_size = struct.unpack_from("<III", chunk, 136)
    end = codec.HEADER_SIZE + payload_size
    return chunk[codec.HEADER_SIZE:end], chunk[end:end + bits_size], raw_size


def _with_payload(chunk: bytes, payload: bytes, raw_size: int, bits: bytes = b"") -> bytes:
    """The chunk's header (sizes updated) with another zstd payload and packed bits."""
    header = bytearray(chunk[:codec.HEADER_SIZE])
    struct.pack_into("<III", header, 136, raw_size, len(payload), len(bits))
    return bytes(header) + payload + bits


def _with_raw(chunk: bytes, raw: bytes, bits: bytes = b"") -> bytes:
    """The chunk with another uncompressed payload (compressed here) and packed bits."""
    return _with_payload(chunk, zstandard.ZstdCompressor(level=1).compress(raw), len(raw), bits)


def _HEADER_VERSION(chunk: bytes) -> int:  # noqa: N802
    """The format version a chunk's header states."""
    return struct.unpack_from("<H", chunk, 4)[0]


def _raw(chunk: bytes) -> bytearray:
    """The chunk's payload, decompressed."""
    return bytearray(zstandard.ZstdDecompressor().decompress(_parts(chunk)[0]))


class _Case(unittest.TestCase):
    """Comparison of a decoded frame with the C++ decoder's."""

    def assertBitIdentical(self, actual, file, shape):  # noqa: N802
        """actual holds the same float32 bits as the C++ decoder's array in `file`."""
        self.assertIsNotNone(file)
        self.assertIsInstance(actual, np.ndarray)
        self.assertEqual(actual.dtype, np.float32)
        self.assertEqual(actual.shape, shape)
        expected = _vectors.array(file)
        self.assertEqual(expected.size, actual.size)
        self.assertTrue(np.array_equal(np.ascontiguousarray(actual).reshape(-1).view(np.uint32),
                                       expected.view(np.uint32)),
                        "%s differs in %d of %d values" % (
                            file, int(np.count_nonzero(actual.reshape(-1) != expected)),
                            actual.size))

    def assertFrame(self, frame, expected):  # noqa: N802
        """frame is what the C++ decoder made of the same chunks (manifest entry `expected`)."""
        self.assertIsNotNone(frame)
        self.assertIsInstance(frame, codec.Frame)
        for key in ("frame_seq", "step", "keyframe", "count", "stride", "fields",
                    "detail_threshold"):
            self.assertEqual(getattr(frame, key), expected[key], key)
        self.assertEqual(frame.ids.dtype, np.uint32)
        self.assertEqual(frame.ids.tolist(), expected["ids"])
        self.assertEqual(frame.time, float.fromhex(expected["time"]))
        n = expected["count"]
        self.assertBitIdentical(frame.positions, expected["positions"], (n, 3))
        for key, shape in (("speed", (n,)), ("velocities", (n, 3)), ("densities", (n,))):
            if expected[key] is None:
                self.assertIsNone(getattr(frame, key), key)
            else:
                self.assertBitIdentical(getattr(frame, key), expected[key], shape)
        self.assertEqual(tuple(frame.position_error),
                         tuple(float.fromhex(e) for e in expected["position_error"]))
        for key in ("speed_error", "velocity_error", "density_error"):
            self.assertEqual(getattr(frame, key), float.fromhex(expected[key]), key)

    def feed(self, decoder, frame, order=None):
        """Adds a frame's chunks one by one (in `order` if given); returns the last result and
        checks that only the last chunk completes the frame."""
        chunks = frame["chunk_bytes"]
        order = range(len(chunks)) if order is None else order
        result = None
        for i, index in enumerate(order):
            result = decoder.add_chunk(chunks[index])
            if i + 1 < len(chunks):
                self.assertIsNone(result, "frame %d complete early" % frame["frame_seq"])
        return result

    def assertRefused(self, decoder, chunk, message):  # noqa: N802
        """add_chunk raises DecodeError with exactly `message`."""
        with self.assertRaises(DecodeError) as caught:
            decoder.add_chunk(chunk)
        self.assertEqual(str(caught.exception), message)


class VectorTest(_Case):
    """The Python decoder gives the C++ decoder's frames, bit for bit."""

    def test_scenarios_cover_what_they_claim(self):
        self.assertEqual(set(_vectors.scenarios),
                         {"a_all_fields", "b_stride_low_bits", "c_empty", "d_extreme_bits",
                          "e_octahedral_velocity", "f_detail_subset", "g_explicit_ids"})
        a = _vectors.frames("a_all_fields")
        self.assertEqual([f["keyframe"] for f in a], [True, False, False, False, True, False])
        self.assertTrue(all(len(f["chunks"]) == 3 for f in a))
        b = _vectors.frames("b_stride_low_bits")
        self.assertEqual([f["count"] for f in b], [834] * 4)
        self.assertEqual([len(f["chunks"]) for f in b], [3] * 4)
        self.assertEqual([f["count"] for f in _vectors.frames("c_empty")], [0, 0])
        d = _vectors.frames("d_extreme_bits")
        self.assertEqual([f["keyframe"] for f in d], [True, False, False, False, False, True,
                                                       False])
        e = _vectors.frames("e_octahedral_velocity")
        self.assertEqual([f["keyframe"] for f in e], [True, False, False, False, False, True])
        self.assertTrue(all(_HEADER_VERSION(f["chunk_bytes"][0]) == 2 for f in e))
        self.assertTrue(all(_HEADER_VERSION(f["chunk_bytes"][0]) == 1 for f in a))
        f = _vectors.frames("f_detail_subset")
        self.assertTrue(all(_HEADER_VERSION(x["chunk_bytes"][0]) == 3 for x in f))
        self.assertEqual([x["keyframe"] for x in f], [True, False, False, False])
        # About 30% of the 3000 particles, the same ones in every frame.
        self.assertTrue(800 < f[0]["count"] < 1000)
        self.assertTrue(all(x["ids"] == f[0]["ids"] for x in f))

    def test_explicit_id_frames_carry_their_ids_in_keyframes(self):
        g = _vectors.frames("g_explicit_ids")
        self.assertTrue(all(_HEADER_VERSION(x["chunk_bytes"][0]) == 4 for x in g))
        self.assertEqual([x["keyframe"] for x in g], [True, False, True, False])
        decoder = FrameDecoder()
        for x in g:
            frame = decoder.add_chunks(x["chunk_bytes"])
            self.assertTrue(frame.explicit_ids)
            self.assertAlmostEqual(frame.count / 3000, 0.4, places=2)
            self.assertFrame(frame, x)
        self.assertNotEqual(g[0]["ids"], g[2]["ids"])
        self.assertEqual(g[2]["ids"], g[3]["ids"])

    def test_detail_subset_frames_name_their_particles(self):
        decoder = FrameDecoder()
        for f in _vectors.frames("f_detail_subset"):
            frame = decoder.add_chunks(f["chunk_bytes"])
            self.assertAlmostEqual(frame.detail_fraction, 0.3, places=6)
            ranks = detail.detail_rank(frame.ids)
            self.assertTrue(np.all(ranks < frame.detail_threshold))
            self.assertTrue(np.all(np.diff(frame.ids.astype(np.int64)) > 0))
        # Every id of the scene not in the frame has a rank at or above the threshold.
        rest = np.setdiff1d(np.arange(3000, dtype=np.uint32), frame.ids)
        self.assertTrue(np.all(detail.detail_rank(rest) >= frame.detail_threshold))
        # splitmix64 seeded with 0: its first two outputs (the reference sequence).
        self.assertEqual(detail.splitmix64(np.array([0, 0x9E3779B97F4A7C15], np.uint64)).tolist(),
                         [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4])
        # A threshold that cannot select `count` particles is a corrupt header.
        chunks = [_with_header(c, 148, "I", 1)
                  for c in _vectors.frames("f_detail_subset")[0]["chunk_bytes"]]
        with self.assertRaises(DecodeError) as caught:
            FrameDecoder().add_chunks(chunks)
        self.assertEqual(str(caught.exception), "corrupt frame header: count %d is more "
                         "particles than detail threshold 1 selects" % frame.count)

    def test_octahedral_frames_say_so(self):
        decoder = FrameDecoder()
        for f in _vectors.frames("e_octahedral_velocity"):
            frame = decoder.add_chunks(f["chunk_bytes"])
            self.assertEqual(frame.velocity_encoding, codec.VELOCITY_OCTAHEDRAL)
        frame = FrameDecoder().add_chunks(_vectors.frames("a_all_fields")[0]["chunk_bytes"])
        self.assertEqual(frame.velocity_encoding, codec.VELOCITY_COMPONENTS)

    def test_chunks_one_by_one(self):
        for name in _vectors.scenarios:
            with self.subTest(scenario=name):
                decoder = FrameDecoder()
                self.assertTrue(decoder.waiting_for_keyframe)
                for frame in _vectors.frames(name):
                    self.assertFrame(self.feed(decoder, frame), frame)
                    self.assertFalse(decoder.waiting_for_keyframe)

    def test_chunks_in_reverse_order_within_a_frame(self):
        for name in ("a_all_fields", "b_stride_low_bits", "d_extreme_bits"):
            with self.subTest(scenario=name):
                decoder = FrameDecoder()
                for frame in _vectors.frames(name):
                    order = reversed(range(len(frame["chunk_bytes"])))
                    self.assertFrame(self.feed(decoder, frame, order), frame)

    def test_add_chunks_one_frame_at_a_time(self):
        for name in _vectors.scenarios:
            with self.subTest(scenario=name):
                decoder = FrameDecoder()
                for frame in _vectors.frames(name):
                    self.assertFrame(decoder.add_chunks(frame["chunk_bytes"]), frame)

    def test_add_chunks_whole_stream_returns_the_last_frame(self):
        frames = _vectors.frames("a_all_fields")
        decoder = FrameDecoder()
        chunks = [bytearray(c) for f in frames for c in f["chunk_bytes"]]  # any buffer type
        self.assertFrame(decoder.add_chunks(chunks), frames[-1])
        # It is the reference of what follows: the stream goes on.
        self.assertFalse(decoder.waiting_for_keyframe)

    def test_a_trailing_skippable_frame_is_accepted(self):
        # As ZSTD_decompressDCtx in the C++ decoder.
        frame = _vectors.frames("a_all_fields")[0]
        chunks = list(frame["chunk_bytes"])
        skippable = struct.pack("<II", 0x184D2A50, 3) + b"abc"
        payload, bits, raw_size = _parts(chunks[1])
        chunks[1] = _with_payload(chunks[1], payload + skippable, raw_size, bits)
        self.assertFrame(FrameDecoder().add_chunks(chunks), frame)


class StreamTest(_Case):
    """The state machine: what is refused, what is dropped, how a stream recovers."""

    def setUp(self):
        self.a = _vectors.frames("a_all_fields")

    def chunk(self, frame, index=0):
        """Chunk `index` of frame `frame` of scenario a."""
        return self.a[frame]["chunk_bytes"][index]

    def test_truncated_and_oversized_chunks(self):
        decoder = FrameDecoder()
        self.assertRefused(decoder, self.chunk(0)[:100],
                           "truncated chunk: 100 bytes, the header alone is 152")
        self.assertRefused(decoder, b"", "truncated chunk: 0 bytes, the header alone is 152")
        payload = len(self.chunk(0)) - codec.HEADER_SIZE  # zstd data and packed bits
        self.assertRefused(decoder, self.chunk(0)[:-1],
                           "truncated or oversized chunk: header says %d payload bytes, %d "
                           "present" % (payload, payload - 1))
        self.assertRefused(decoder, self.chunk(0) + b"\0",
                           "truncated or oversized chunk: header says %d payload bytes, %d "
                           "present" % (payload, payload + 1))
        # A refused header changes nothing: the stream decodes as if it had not come.
        self.assertFrame(self.feed(decoder, self.a[0]), self.a[0])
        self.assertFrame(self.feed(decoder, self.a[1]), self.a[1])

    def test_bad_magic(self):
        self.assertRefused(FrameDecoder(), b"X" + self.chunk(0)[1:],
                           "not a DySAQUASIMs frame (bad magic)")

    def test_newer_and_older_versions(self):
        newer = bytearray(self.chunk(0))
        newer[4] = 5
        self.assertRefused(FrameDecoder(), bytes(newer),
                           "frame format version 5 is newer than this decoder (version 4); "
                           "update the client")
        self.assertRefused(FrameDecoder(), _with_header(self.chunk(0), 4, "H", 0),
                           "frame format version 0 is not supported by this decoder "
                           "(version 4); update the client")
        # A version 1 frame labelled version 2 decodes the same: version 2 only adds a flag.
        relabelled = [_with_header(c, 4, "H", 2) for c in self.a[0]["chunk_bytes"]]
        self.assertFrame(FrameDecoder().add_chunks(relabelled), self.a[0])

    def test_corrupt_header_fields(self):
        c = self.chunk(0)
        cases = [
            (_with_header(c, 148, "I", 1), "reserved bytes set"),
            (_with_header(c, 6, "H", 3), "unknown flags 3 for version 1"),
            (_with_header(_with_header(c, 4, "H", 2), 6, "H", 5), "unknown flags 5 for version 2"),
            (_with_header(_with_header(_with_header(c, 4, "H", 2), 6, "H", 3), 44, "I", 1),
             "octahedral flag without velocity"),
            (_with_header(c, 44, "I", 2), "fields 2 (positions must be present, bits 0-3 only)"),
            (_with_header(c, 44, "I", 17),
             "fields 17 (positions must be present, bits 0-3 only)"),
            (_with_header(c, 12, "I", (1 << 26) + 1), "count 67108865 over the limit"),
            (_with_header(c, 52, "I", 0), "stride 0"),
            (_with_header(c, 32, "H", 3), "chunk index out of range"),
            (_with_header(c, 34, "H", 0), "chunk index out of range"),
            (_with_header(c, 36, "I", 2500), "chunk particles out of range"),
            (_with_header(c, 40, "I", 0), "empty chunk"),
            (_with_header(c, 24, "d", float("nan")), "time is not finite"),
            (_with_header(c, 48, "B", 0), "bit width 0"),
            (_with_header(c, 48, "B", 25), "bit width 25"),
            (_with_header(c, 51, "B", 17), "bit width 17"),
            (_with_header(c, 80, "d", -5.0), "range [-5, -5]"),
            (_with_header(c, 112, "d", float("inf")), "range [-inf, inf]"),
            (_with_header(_with_header(c, 44, "I", 1), 50, "B", 0),
             "bits set for an absent field"),
        ]
        for chunk, message in cases:
            with self.subTest(message=message):
                self.assertRefused(FrameDecoder(), chunk, "corrupt frame header: " + message)

    def test_corrupt_payload_then_recovery_on_the_next_keyframe(self):
        decoder = FrameDecoder()
        self.assertFrame(self.feed(decoder, self.a[0]), self.a[0])
        broken = bytearray(self.chunk(1, 1))
        broken[codec.HEADER_SIZE:codec.HEADER_SIZE + 4] = b"\0\0\0\0"  # the zstd magic
        self.assertIsNone(decoder.add_chunk(self.chunk(1, 0)))
        self.assertRefused(decoder, bytes(broken), "corrupt chunk 1 of frame 1: payload size "
                                                   "does not match the header")
        self.assertTrue(decoder.waiting_for_keyframe)
        self.assertIsNone(decoder.add_chunk(self.chunk(1, 2)))
        for f in (2, 3):
            self.assertIsNone(decoder.add_chunks(self.a[f]["chunk_bytes"]))
            self.assertTrue(decoder.waiting_for_keyframe)
        for f in (4, 5):
            self.assertFrame(self.feed(decoder, self.a[f]), self.a[f])
            self.assertFalse(decoder.waiting_for_keyframe)

    def test_corrupt_payloads(self):
        c = self.chunk(0)
        payload, bits, raw_size = _parts(c)
        raw = _raw(c)
        n, m = 8, 1000  # components (x, y, z, speed, velocity x, y, z, density), particles
        split = bytearray(raw)
        split[0] = 25
        planes = bytearray(raw)
        planes[1] = 5
        gap = bytearray(raw)  # a plane more than the data
        gap[1] += 1 if gap[1] < 4 else -1
        # Built from scratch: position x with the given split and planes, nothing else.
        empty = bytes(2 * n)
        wide = bytes([24, 2]) + empty[2:] + bytes(2 * m)
        negative = bytes([0, 1]) + empty[2:] + b"\1" + bytes(m - 1)  # z_0 = 1: q_0 = -1
        broken_block = bytearray(payload)  # the first block's type: 3 is reserved
        broken_block[zstandard.frame_header_size(payload)] |= 0b110
        cases = [
            (_with_payload(c, payload, raw_size + 1, bits),
             "payload size does not match the header"),
            (_with_payload(c, b"", 0, bits), "payload size does not match the header"),
            (_with_raw(c, bytes(n * (2 + 4 * m) + 1)), "raw size too large"),
            (_with_payload(c, bytes(broken_block), raw_size, bits),
             "payload does not decompress"),
            (_with_payload(c, payload + b"junk", raw_size, bits), "payload does not decompress"),
            (_with_payload(c, payload + payload, raw_size, bits), "payload does not decompress"),
            (_with_raw(c, bytes(2 * n - 1)), "payload too short"),
            (_with_raw(c, bytes(split), bits), "split beyond 24 bits"),
            (_with_raw(c, bytes(planes), bits), "more than 4 byte planes"),
            (_with_raw(c, bytes(gap), bits), "payload size does not match its byte planes"),
            (_with_payload(c, payload, raw_size, bits + b"\0"),
             "packed bits do not match their split"),
            (_with_payload(c, payload, raw_size, bits[:-1]),
             "packed bits do not match their split"),
            (_with_raw(c, wide, bytes(3 * m)), "residual wider than 32 bits"),
            (_with_raw(c, negative), "decoded value outside its range"),
        ]
        for chunk, message in cases:
            with self.subTest(message=message):
                decoder = FrameDecoder()
                self.assertRefused(decoder, chunk, "corrupt chunk 0 of frame 0: " + message)
                self.assertTrue(decoder.waiting_for_keyframe)

    def test_a_chunk_built_by_hand(self):
        # Every residual 0 in a keyframe: every value is the low end of its range.
        c = self.chunk(0)
        decoder = FrameDecoder()
        self.assertIsNone(decoder.add_chunk(_with_raw(c, bytes(16))))
        frame = decoder.add_chunks([self.chunk(0, 1), self.chunk(0, 2)])
        lo = np.array(struct.unpack_from("<3d", c, 56), np.float32)
        self.assertTrue(np.array_equal(frame.positions[:1000], np.tile(lo, (1000, 1))))
        self.assertTrue(np.array_equal(frame.speed[:1000], np.zeros(1000, np.float32)))
        expected = _vectors.array(self.a[0]["positions"]).reshape(-1, 3)
        self.assertTrue(np.array_equal(frame.positions[1000:], expected[1000:]))

    def test_a_chunk_received_twice(self):
        decoder = FrameDecoder()
        self.assertIsNone(decoder.add_chunk(self.chunk(0, 0)))
        self.assertRefused(decoder, self.chunk(0, 0), "chunk 0 of frame 0 received twice")
        with self.assertRaisesRegex(DecodeError, "^chunk 1 of frame 0 received twice$"):
            decoder.add_chunks([self.chunk(0, 1), self.chunk(0, 1)])
        # Refused chunks change nothing (in both decoders).
        self.assertIsNone(decoder.add_chunk(self.chunk(0, 1)))
        self.assertFrame(decoder.add_chunk(self.chunk(0, 2)), self.a[0])
        self.assertFrame(self.feed(decoder, self.a[1]), self.a[1])

    def test_a_chunk_that_does_not_match_its_frame(self):
        decoder = FrameDecoder()
        self.assertIsNone(decoder.add_chunk(self.chunk(0, 0)))
        self.assertRefused(decoder, _with_header(self.chunk(0, 1), 16, "Q", 1),
                           "chunk 1 does not match the other chunks of frame 0")
        self.assertRefused(decoder, _with_header(self.chunk(0, 2), 6, "H", 0),
                           "chunk 2 does not match the other chunks of frame 0")
        self.assertIsNone(decoder.add_chunk(self.chunk(0, 1)))
        self.assertFrame(decoder.add_chunk(self.chunk(0, 2)), self.a[0])

    def test_chunks_must_cover_the_frame_exactly_once(self):
        decoder = FrameDecoder()
        self.assertIsNone(decoder.add_chunk(self.chunk(0, 0)))
        # Chunk 1 of scenario a starts at particle 1000; claiming 700 would overlap chunk 0.
        self.assertRefused(decoder, _with_header(self.chunk(0, 1), 36, "I", 700),
                           "chunk 1 of frame 0 covers particles [700, 1700), which does not fit "
                           "the frame's other chunks")
        self.assertIsNone(decoder.add_chunk(self.chunk(0, 1)))
        self.assertFrame(decoder.add_chunk(self.chunk(0, 2)), self.a[0])

    def test_late_joiner_waits_for_a_keyframe(self):
        decoder = FrameDecoder()
        for f in (1, 2, 3):
            for chunk in self.a[f]["chunk_bytes"]:
                self.assertIsNone(decoder.add_chunk(chunk))
                self.assertTrue(decoder.waiting_for_keyframe)
        for f in (4, 5):
            self.assertFrame(self.feed(decoder, self.a[f]), self.a[f])
            self.assertFalse(decoder.waiting_for_keyframe)

    def test_an_incomplete_frame_is_lost(self):
        decoder = FrameDecoder()
        for f in (0, 1):
            self.assertFrame(self.feed(decoder, self.a[f]), self.a[f])
        self.assertIsNone(decoder.add_chunk(self.chunk(2, 0)))
        self.assertIsNone(decoder.add_chunk(self.chunk(2, 2)))
        self.assertFalse(decoder.waiting_for_keyframe)  # chunk 1 may still come
        self.assertIsNone(decoder.add_chunk(self.chunk(3, 0)))  # it did not
        self.assertTrue(decoder.waiting_for_keyframe)
        self.assertIsNone(decoder.add_chunks(self.a[3]["chunk_bytes"][1:]))
        self.assertFrame(decoder.add_chunks(self.a[4]["chunk_bytes"]), self.a[4])
        self.assertFrame(decoder.add_chunks(self.a[5]["chunk_bytes"]), self.a[5])

    def test_a_skipped_frame_stops_the_deltas(self):
        decoder = FrameDecoder()
        for f in (0, 1):
            self.assertFrame(self.feed(decoder, self.a[f]), self.a[f])
        self.assertIsNone(decoder.add_chunks(self.a[3]["chunk_bytes"]))
        self.assertTrue(decoder.waiting_for_keyframe)
        self.assertFrame(decoder.add_chunks(self.a[4]["chunk_bytes"]), self.a[4])

    def test_a_delta_frame_of_another_layout_is_not_decoded(self):
        # Frame 1 of scenario b follows frame 0 of scenario a by number, not by layout.
        decoder = FrameDecoder()
        self.assertFrame(self.feed(decoder, self.a[0]), self.a[0])
        b1 = _vectors.frames("b_stride_low_bits")[1]
        self.assertIsNone(decoder.add_chunks(b1["chunk_bytes"]))
        self.assertTrue(decoder.waiting_for_keyframe)

    def test_a_keyframe_decodes_after_anything(self):
        decoder = FrameDecoder()
        self.assertFrame(self.feed(decoder, self.a[0]), self.a[0])
        d = _vectors.frames("d_extreme_bits")
        self.assertFrame(decoder.add_chunks(d[0]["chunk_bytes"]), d[0])
        self.assertFrame(decoder.add_chunks(d[1]["chunk_bytes"]), d[1])


if __name__ == "__main__":
    if len(sys.argv) > 1 and not sys.argv[1].startswith("-"):
        os.environ["DYSA_CODEC_VECTORS"] = sys.argv.pop(1)
    unittest.main()  # exits with 1 when a test fails
