// Quantisation (FORMAT.md, "Quantisation"): the ranges a keyframe fixes, values to levels in
// them and back, and the error bound that follows.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "chunk_header.h"
#include "components.h"
#include "dysa/codec/frame_codec.h"

namespace dysa::codec {

// Quantised values per component, each frame-sized (empty for an absent component). Large
// buffers, allocated once and recycled from frame to frame: fresh multi-megabyte allocations
// cost more in page faults than the coding itself.
using Values = std::vector<std::vector<uint32_t>>;

inline uint32_t Levels(int bits) { return bits >= 32 ? 0xFFFFFFFFu : (1u << bits) - 1; }

// A recycled buffer (or a new one) sized for `count` values of each component the header has.
Values TakeValues(std::vector<Values>& spare, uint32_t count, const ChunkHeader& h);

// True when a gathered value falls outside the current keyframe's range [lo, hi] of its
// component: the frame must be a keyframe with new ranges.
bool LeavesRanges(const Extremes& e, std::span<const Component> comps, uint32_t count,
                  const std::array<double, kComponents>& lo,
                  const std::array<double, kComponents>& hi);

// A keyframe's range of each component: the values' extremes with headroom where values move
// (so later delta frames stay inside), the domain for positions inside it.
void ChooseRanges(const FrameInput& f, std::span<const Component> comps, bool octahedral,
                  uint32_t count, Extremes e, std::array<double, kComponents>& lo,
                  std::array<double, kComponents>& hi);

// Quantises each component of `values` (count each) over the header's ranges and bits into q.
void QuantizeComponents(const ChunkHeader& h, std::span<const Component> comps,
                        const std::vector<std::vector<float>>& values, uint32_t count, Values& q);

// Dequantises component c of the chunk `h` from q into the frame's float array. Not for the
// octahedral velocity components, which decode together (octahedral_velocity.h).
void DequantizeComponent(const ChunkHeader& h, Component c, const Values& q, Frame& frame);

// The frame's error bounds from its header's ranges, bits and velocity encoding; 0 for an
// absent field.
void SetErrorBounds(const ChunkHeader& h, Frame& frame);

}  // namespace dysa::codec
