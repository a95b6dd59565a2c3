"""Progressive completion of a view stream (docs/server.md, "View-dependent detail"): a frame
that refines the one shown carries other particles of the same simulation frame; the frame to
show is the union, in id order."""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from dysa.codec import Frame

__all__ = ["merge_refinement"]


def merge_refinement(shown: Frame, more: Frame) -> Frame:
    """The frame to show after a refinement (FrameMessage.refines): the union of `shown` and
    `more`, other particles of the same simulation frame, in increasing id order. The values
    are the decoded ones, untouched, so once the refinements complete the frame it is
    bit-exactly the full-detail frame (the C++ dysa::codec::MergeRefinement).

    Raises ValueError when the fields differ or a particle is in both.
    """
    if shown.fields != more.fields:
        raise ValueError("refinement: fields differ from the frame shown")
    ids = np.concatenate([shown.ids, more.ids])
    order = np.argsort(ids, kind="stable")
    ids = ids[order]
    if ids.size > 1 and not np.all(np.diff(ids.astype(np.int64)) > 0):
        raise ValueError("refinement: a particle is already in the frame shown")

    def join(a: Optional[np.ndarray], b: Optional[np.ndarray]) -> Optional[np.ndarray]:
        return None if a is None or b is None else np.concatenate([a, b])[order]

    return Frame(
        frame_seq=more.frame_seq, step=more.step, time=more.time, keyframe=more.keyframe,
        count=int(ids.size), stride=more.stride, fields=more.fields,
        positions=join(shown.positions, more.positions), speed=join(shown.speed, more.speed),
        velocities=join(shown.velocities, more.velocities),
        densities=join(shown.densities, more.densities),
        velocity_encoding=more.velocity_encoding,
        position_error=tuple(max(a, b) for a, b in zip(shown.position_error,
                                                      more.position_error)),
        speed_error=max(shown.speed_error, more.speed_error),
        velocity_error=max(shown.velocity_error, more.velocity_error),
        density_error=max(shown.density_error, more.density_error),
        detail_threshold=_grown_threshold(shown, int(ids.size)), ids=ids, explicit_ids=True)


def _grown_threshold(shown: Frame, count: int) -> int:
    """The detail threshold of the shown frame's fraction grown by the particles added (the
    C++ MergeRefinement's rule; FrameStream sets 0 once the frame is complete)."""
    if shown.count == 0:
        return 0
    fraction = min(1.0, shown.detail_fraction * count / shown.count)
    if fraction >= 1.0:
        return 0
    return min(0xFFFFFFFF, max(1, math.ceil(fraction * 4294967296.0)))
