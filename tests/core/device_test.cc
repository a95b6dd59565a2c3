// Tests of dysa/core/device.h: parsing --device, and what a machine without a usable GPU says.
// They run everywhere; on a machine with a GPU the unavailable-GPU checks take the GPU's side.
#include "dysa/core/device.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dysa/core/scene.h"
#include "dysa/core/simulation.h"
#include "dysa/core/solver.h"

namespace dysa {
namespace {

using ::testing::HasSubstr;

TEST(ParseDeviceTest, AcceptsCpuCudaAndAnOrdinal) {
  EXPECT_FALSE(ParseDevice("cpu").is_cuda());
  EXPECT_TRUE(ParseDevice("cuda").is_cuda());
  EXPECT_EQ(ParseDevice("cuda").index, 0);
  EXPECT_EQ(ParseDevice("cuda:3").index, 3);
  EXPECT_EQ(ParseDevice("cuda:63").index, 63);
  EXPECT_EQ(ParseDevice("cuda:7").ToString(), "cuda:7");
  EXPECT_EQ(ParseDevice("cpu").ToString(), "cpu");
}

TEST(ParseDeviceTest, RejectsEverythingElseNamingTheForms) {
  for (const char* text : {"", "gpu", "CUDA", "cuda:", "cuda:-1", "cuda:64", "cuda:1x", "cuda:0:1",
                           "cpu:0", " cuda"}) {
    try {
      ParseDevice(text);
      ADD_FAILURE() << "accepted \"" << text << "\"";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.field(), "device");
      EXPECT_THAT(e.what(), HasSubstr("cpu, cuda or cuda:N")) << text;
    }
  }
}

TEST(QueryDeviceTest, TheCpuIsAlwaysThere) {
  EXPECT_EQ(DeviceUnavailableReason(Device{}), "");
  EXPECT_EQ(QueryDevice(Device{}).name, "cpu");
  EXPECT_EQ(QueryDevice(Device{}).Describe(Device{}), "cpu");
}

TEST(QueryDeviceTest, AMissingGpuIsAClearErrorNotACrash) {
  // An ordinal no machine has: refused on every machine, naming what is missing.
  const Device absent{Device::Kind::kCuda, 63};
  const std::string reason = DeviceUnavailableReason(absent);
  ASSERT_NE(reason, "");
  if (!CudaBackendBuilt()) {
    EXPECT_THAT(reason, HasSubstr("no CUDA backend"));
  } else {
    EXPECT_THAT(reason, ::testing::AnyOf(HasSubstr("no usable CUDA GPU"),
                                         HasSubstr("cuda:63 does not exist")));
  }
  try {
    QueryDevice(absent);
    ADD_FAILURE() << "QueryDevice accepted cuda:63";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "device");
    EXPECT_EQ(e.message(), reason);
  }
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 4);
  EXPECT_THROW(Simulation(scene, absent), ConfigError);
}

TEST(QueryDeviceTest, CudaZeroRunsOrSaysWhyNot) {
  const Device gpu{Device::Kind::kCuda, 0};
  const std::string reason = DeviceUnavailableReason(gpu);
  Scene scene = LoadScene("seed_basic");
  SetParam(scene.params, "particle_quantity", 4);
  if (reason.empty()) {
    const DeviceInfo info = QueryDevice(gpu);
    EXPECT_NE(info.name, "");
    EXPECT_GT(info.memory_bytes, 0u);
    EXPECT_GE(info.compute_capability, 50);
    Simulation sim(scene, gpu);
    EXPECT_THAT(sim.DeviceDescription(), HasSubstr("cuda:0 " + info.name));
  } else {
    std::printf("no GPU here: %s\n", reason.c_str());
    try {
      Simulation sim(scene, gpu);
      ADD_FAILURE() << "a simulation started on an unusable GPU";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.field(), "device");
      EXPECT_THAT(e.message(), HasSubstr("--device cpu"));
    }
  }
}

TEST(QueryDeviceTest, EverySolverRunsOnTheGpuOrSaysWhyNot) {
  const Device gpu{Device::Kind::kCuda, 0};
  const bool usable = DeviceUnavailableReason(gpu).empty();
  for (const SolverInfo& info : SolverRegistry()) {
    Scene scene = LoadScene(info.physical ? "hydrostatic_tank" : "seed_basic");
    scene.solver = std::string(info.name);
    if (!info.physical) SetParam(scene.params, "particle_quantity", 4);
    if (usable) {
      Simulation sim(scene, gpu);
      sim.Step();
      EXPECT_EQ(sim.alarm(), "") << info.name;
      continue;
    }
    try {
      Simulation sim(scene, gpu);
      ADD_FAILURE() << info.name << " started on an unusable GPU";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.field(), "device") << info.name;
    }
  }
}

}  // namespace
}  // namespace dysa
