#include "dysa/core/device.h"

#include <charconv>
#include <cstdio>

#include "dysa/core/step_backend.h"
#include "dysa/core/types.h"
#include "gpu_backend.h"

namespace dysa {

std::string Device::ToString() const { return is_cuda() ? "cuda:" + std::to_string(index) : "cpu"; }

Device ParseDevice(std::string_view text) {
  const auto bad = [&] {
    return ConfigError("device", "\"" + std::string(text.substr(0, 64)) +
                                     "\" is not a device; use cpu, cuda or cuda:N (N in [0, 63])");
  };
  if (text == "cpu") return Device{};
  if (text == "cuda") return Device{Device::Kind::kCuda, 0};
  constexpr std::string_view kPrefix = "cuda:";
  if (text.substr(0, kPrefix.size()) != kPrefix) throw bad();
  const std::string_view digits = text.substr(kPrefix.size());
  int index = -1;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), index);
  if (error != std::errc() || end != digits.data() + digits.size() || digits.empty() || index < 0 ||
      index > 63) {
    throw bad();
  }
  return Device{Device::Kind::kCuda, index};
}

std::string DeviceInfo::Describe(const Device& device) const {
  if (!device.is_cuda()) return "cpu";
  char text[160];
  std::snprintf(text, sizeof text, "%s %s, %.1f GiB, sm_%d", device.ToString().c_str(),
                name.c_str(), double(memory_bytes) / double(1ull << 30), compute_capability);
  return text;
}

std::unique_ptr<StepBackend> CreateDeviceStepBackend(const Device& device,
                                                     std::string_view solver) {
  return CreateGpuBackend(device, solver);
}

}  // namespace dysa
