"""Level of detail by rank (server/codec/include/dysa/codec/detail_subset.h).

Every particle id has a fixed pseudo-random rank in [0, 2**32): the upper 32 bits of
splitmix64(id). A frame of detail threshold T holds the particles whose rank is below T (a
fraction T / 2**32 of them; T = 0: no selection). The subset is stable from frame to frame,
nested (a larger T only adds particles) and spatially even. A frame's header carries T, so its
particle ids follow from T, its stride and its count: `kept_ids` computes them.
"""

from __future__ import annotations

from typing import Dict, Tuple

import numpy as np

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


def splitmix64(ids: np.ndarray) -> np.ndarray:
    """splitmix64's output for each value of `ids` (uint64 arithmetic modulo 2**64)."""
    with np.errstate(over="ignore"):
        x = ids.astype(np.uint64) + _GAMMA
        x = (x ^ (x >> np.uint64(30))) * _M1
        x = (x ^ (x >> np.uint64(27))) * _M2
        return x ^ (x >> np.uint64(31))


def detail_rank(ids: np.ndarray) -> np.ndarray:
    """Each id's rank, uint32, uniform over [0, 2**32)."""
    return (splitmix64(np.asarray(ids)) >> np.uint64(32)).astype(np.uint32)


def detail_fraction(threshold: int) -> float:
    """The fraction of the particles a threshold keeps (1 for 0)."""
    return 1.0 if threshold == 0 else threshold / 4294967296.0


_CACHE: Dict[Tuple[int, int, int], np.ndarray] = {}


def kept_ids(count: int, stride: int, threshold: int, limit: int = 20_000_000) -> np.ndarray:
    """The ids of a frame's `count` particles: the first `count` ids (multiples of `stride`,
    below `limit`) whose rank is below `threshold`; k * stride when threshold is 0.

    Raises ValueError when fewer than `count` ids qualify (a corrupt header).
    """
    if threshold == 0:
        return np.arange(count, dtype=np.uint32) * np.uint32(stride)
    key = (count, stride, threshold)
    cached = _CACHE.get(key)
    if cached is not None:
        return cached
    fraction = detail_fraction(threshold)
    found = []
    have = 0
    start = 0
    while have < count and start < limit:
        span = min(limit - start, max(1 << 16, int((count - have) / fraction * 1.2) * stride))
        ids = np.arange(start, start + span, stride, dtype=np.uint64)
        ids = ids[detail_rank(ids) < np.uint32(threshold)]
        found.append(ids[:count - have].astype(np.uint32))
        have += len(found[-1])
        start += -(-span // stride) * stride
    if have < count:
        raise ValueError("count %d is more particles than detail threshold %d selects"
                         % (count, threshold))
    result = np.concatenate(found) if found else np.zeros(0, np.uint32)
    if len(_CACHE) > 8:
        _CACHE.clear()
    _CACHE[key] = result
    return result
