// The components of a frame (FORMAT.md, "Payload"), and the encoder's first stage: gathering
// each present component's values from the caller's arrays, in id order of the kept particles.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "dysa/codec/frame_codec.h"

namespace dysa::codec {

// Components in payload order (FORMAT.md).
enum Component { kPosX, kPosY, kPosZ, kSpeedC, kVelX, kVelY, kVelZ, kDensityC, kComponents };

inline bool IsVelocity(Component c) { return c >= kVelX && c <= kVelZ; }

// The smallest and largest gathered value of each component, as doubles.
struct Extremes {
  std::array<double, kComponents> lo{}, hi{};
};

// Checks that the arrays `fields` needs have the sizes of one frame; returns its particle count
// (ids). Throws std::invalid_argument naming the array.
size_t CheckInput(const FrameInput& f, uint32_t fields);

// Checks explicit ids (FrameInput::ids) against a frame of `count` particles: strictly
// increasing, each below count. Throws std::invalid_argument naming the field.
void CheckIds(std::span<const uint32_t> ids, size_t count);

// Widens the position extremes to those of every particle of the frame, not just the sent ones:
// f.position_lo/hi when the caller gave them (has_position_bounds), else a scan of f.positions.
void WidenPositionsToAll(const FrameInput& f, Extremes& e);

// Copies each component in `comps` of the kept particles (ids `kept` when it is not empty, else
// 0, stride, 2 stride, ...) into
// values[c] (count values) and returns their extremes. Speed is |v| computed in double and
// rounded to float; with the octahedral encoding the velocity components are |v|, u and v,
// rounded to float (FORMAT.md, "Velocity"). Min and max are exact, so the result does not depend
// on the thread count.
Extremes GatherComponents(const FrameInput& f, std::span<const Component> comps, uint32_t stride,
                          std::span<const uint32_t> kept, uint32_t count, bool octahedral,
                          std::vector<std::vector<float>>& values);

}  // namespace dysa::codec
