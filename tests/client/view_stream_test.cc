// View-dependent detail over real gRPC, through the C++ client library: SetStreamView steers a
// budgeted stream, the paused server completes the shown frame progressively and FrameAssembler
// assembles it into exactly the full-detail frame; bad cameras are refused naming the field and
// its range while the server goes on.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "dysa/client/client.h"
#include "dysa/client/frame_assembler.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "support/wait_for.h"

namespace dysa::remote {
namespace {

constexpr uint32_t kParticles = 4096;  // seed_basic at particle_quantity 16

class Fixture {
 public:
  Fixture() {
    Scene scene = LoadScene("seed_basic");
    SetParam(scene.params, "particle_quantity", 16);
    service::HostOptions host_options;
    host_options.start_paused = true;
    host_options.solver_threads = 1;
    service::ServerOptions server_options;
    server_options.listen = "127.0.0.1:0";
    host_ = std::make_unique<service::SimulationHost>(std::move(scene), host_options);
    server_ = std::make_unique<service::Server>(*host_, server_options);
    ConnectOptions connect;
    connect.address = "127.0.0.1:" + std::to_string(server_->port());
    client_ = std::make_unique<Client>(connect);
  }
  ~Fixture() {
    client_.reset();
    server_.reset();
    host_.reset();
  }
  Client& client() { return *client_; }

 private:
  std::unique_ptr<service::SimulationHost> host_;
  std::unique_ptr<service::Server> server_;
  std::unique_ptr<Client> client_;
};

// Looks at the fluid's block from in front and above, as the viewer's fitted camera does.
StreamCamera Camera() {
  StreamCamera c;
  c.eye = {0.5, 1.5, 3.5};
  c.target = {0, 0, 0};
  c.fov_y_deg = 45;
  c.aspect = 1.6;
  return c;
}

// Reads until a frame completes; its progress, or complete = false when the stream ended.
FrameProgress NextFrame(FrameStream& stream, FrameAssembler& assembler, codec::Frame& out) {
  FrameMessage message;
  while (stream.Next(message)) {
    const FrameProgress progress = assembler.Add(message, out);
    if (progress.complete) return progress;
  }
  return {};
}

TEST(ViewStreamTest, ThePausedServerCompletesTheShownFrameBitExactly) {
  Fixture f;
  // The full-detail frame, as a stream without a budget gets it.
  codec::Frame full;
  {
    auto stream = f.client().StreamFrames({});
    FrameAssembler assembler;
    ASSERT_TRUE(NextFrame(*stream, assembler, full).complete);
    ASSERT_EQ(full.count, kParticles);
    stream->Cancel();
  }
  // A client's cancel ends its call at once, but the server hears of it asynchronously: the
  // stream stays open there (and in GetStatus) until its reactor is done. Wait for that, so the
  // status below shows only the view stream.
  ASSERT_TRUE(dysa::testing::WaitFor([&] { return f.client().GetStatus().streams.empty(); }, 30))
      << "the cancelled stream is closed on the server";

  StreamOptions options;
  options.particle_budget = 256;
  auto stream = f.client().StreamFrames(options);
  FrameAssembler assembler;
  codec::Frame shown;
  FrameProgress progress = NextFrame(*stream, assembler, shown);
  ASSERT_TRUE(progress.complete);
  ASSERT_NE(progress.stream_id, 0u);
  EXPECT_LE(shown.count, 256u * 1.25);  // a subset by rank: the budget up to sampling spread
  f.client().SetStreamView(progress.stream_id, Camera());
  const ServerStatus status = f.client().GetStatus();
  ASSERT_EQ(status.streams.size(), 1u);
  EXPECT_EQ(status.streams[0].stream_id, progress.stream_id);
  EXPECT_TRUE(status.streams[0].view);

  // The view's subset, then refinements that double it: log2(4096 / 256) = 4 of them.
  int frames = 0;
  uint32_t view_subset = 0;  // particles of the view's own frame, before refinements
  do {
    progress = NextFrame(*stream, assembler, shown);
    ASSERT_TRUE(progress.complete);
    ASSERT_LE(++frames, 1 + 4 + 2) << "completion takes a bounded number of frames";
    if (shown.explicit_ids && !progress.refined) view_subset = shown.count;
  } while (progress.partial || !shown.explicit_ids);
  EXPECT_GT(view_subset, 0u);
  EXPECT_LE(view_subset, 256u) << "a view subset holds the budget exactly";
  EXPECT_TRUE(progress.refined);
  ASSERT_EQ(shown.count, kParticles);
  for (uint32_t k = 0; k < kParticles; ++k) ASSERT_EQ(shown.ids[k], k);
  EXPECT_EQ(std::memcmp(shown.positions.data(), full.positions.data(), 12 * kParticles), 0)
      << "bit-exact quantised positions";
  stream->Cancel();
}

TEST(ViewStreamTest, BadCamerasAreRefusedNamingTheFieldAndTheServerGoesOn) {
  Fixture f;
  const auto refused = [&](uint64_t id, const StreamCamera& camera) -> std::string {
    try {
      f.client().SetStreamView(id, camera);
    } catch (const RpcError& e) {
      return e.code_name() + ": " + e.message();
    }
    return "accepted";
  };
  EXPECT_NE(refused(12345, Camera()).find("NOT_FOUND: stream_id: no open stream 12345"),
            std::string::npos);

  StreamOptions options;
  options.particle_budget = 100;
  auto stream = f.client().StreamFrames(options);
  FrameAssembler assembler;
  codec::Frame frame;
  const FrameProgress progress = NextFrame(*stream, assembler, frame);
  ASSERT_TRUE(progress.complete);
  StreamCamera camera = Camera();
  camera.fov_y_deg = 500;
  EXPECT_EQ(refused(progress.stream_id, camera),
            "INVALID_ARGUMENT: fov_y_deg: allowed range [1, 179] degrees");
  camera = Camera();
  camera.aspect = 0.01;
  EXPECT_EQ(refused(progress.stream_id, camera),
            "INVALID_ARGUMENT: aspect: allowed range [0.05, 20] (width / height)");
  camera = Camera();
  camera.up = {0, 0, 0};
  EXPECT_EQ(refused(progress.stream_id, camera),
            "INVALID_ARGUMENT: up: nonzero and not parallel to target - eye");
  camera = Camera();
  camera.eye[0] = INFINITY;
  EXPECT_EQ(refused(progress.stream_id, camera),
            "INVALID_ARGUMENT: eye: each component finite, in [-1e6, 1e6] m");
  // Nothing of it was applied, and the server goes on.
  const ServerStatus status = f.client().GetStatus();
  ASSERT_EQ(status.streams.size(), 1u);
  EXPECT_FALSE(status.streams[0].view);
  EXPECT_EQ(refused(progress.stream_id, Camera()), "accepted");
  stream->Cancel();
}

}  // namespace
}  // namespace dysa::remote
