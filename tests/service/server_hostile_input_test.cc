// Integration tests of dysa-server's service against hostile input over real gRPC: every reply
// stays under the 4 MiB message limit whatever a loaded scene holds, errors quote at most a
// bounded, escaped part of what the caller sent, log lines stay single lines, and the server
// keeps running and loses nothing.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/service/server.h"
#include "dysa/service/simulation_host.h"
#include "dysa/v1/simulation.grpc.pb.h"

namespace dysa::service {
namespace {

using v1::Simulation;

// gRPC's default limit on a message a client receives.
constexpr size_t kMessageLimit = size_t{4} << 20;
// rpc_status.h's bound on a status message.
constexpr size_t kMaxMessage = 2048;

// A paused host on seed_basic (1,000 particles) logging into `log`, a server on a free port, and
// a client stub with gRPC's default limits.
class Fixture {
 public:
  explicit Fixture(ServerOptions server_options = {}) {
    Scene scene = LoadScene("seed_basic");
    SetParam(scene.params, "particle_quantity", 10);
    HostOptions host_options;
    host_options.start_paused = true;
    host_options.solver_threads = 1;
    host_options.log = [this](const std::string& line) {
      std::lock_guard lock(mu_);
      log_.push_back(line);
    };
    server_options.listen = "127.0.0.1:0";
    host_ = std::make_unique<SimulationHost>(std::move(scene), host_options);
    server_ = std::make_unique<Server>(*host_, server_options);
    stub_ = Simulation::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(server_->port()),
                                                    grpc::InsecureChannelCredentials()));
  }
  ~Fixture() {
    server_.reset();
    host_.reset();
  }
  Simulation::Stub& stub() { return *stub_; }
  std::vector<std::string> log() {
    std::lock_guard lock(mu_);
    return log_;
  }

 private:
  std::mutex mu_;
  std::vector<std::string> log_;
  std::unique_ptr<SimulationHost> host_;
  std::unique_ptr<Server> server_;
  std::unique_ptr<Simulation::Stub> stub_;
};

std::unique_ptr<grpc::ClientContext> Context(const std::string& authorization = "") {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  if (!authorization.empty()) context->AddMetadata("authorization", authorization);
  return context;
}

v1::Status GetStatus(Simulation::Stub& stub) {
  v1::Status status;
  EXPECT_TRUE(stub.GetStatus(Context().get(), {}, &status).ok());
  return status;
}

// Expects INVALID_ARGUMENT with a bounded message that contains `field`, free of control
// characters; returns the message.
std::string ExpectRefused(const grpc::Status& s, const std::string& field) {
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_LE(s.error_message().size(), kMaxMessage);
  EXPECT_NE(s.error_message().find(field), std::string::npos) << s.error_message();
  for (char c : s.error_message()) {
    EXPECT_FALSE(static_cast<unsigned char>(c) < 0x20) << s.error_message();
  }
  return s.error_message();
}

// The largest scene a caller may load: a 256-byte name of 4-byte characters, a 4 KiB
// description, 10,000 box obstacles with every coordinate set (proto3 leaves zeros out).
std::string LargestSceneText() {
  std::string name;
  while (name.size() + 4 <= kMaxSceneNameBytes) name += "\xf0\x9f\x8c\x8a";
  std::string boxes;
  for (size_t i = 0; i < kMaxObstacles; ++i) {
    boxes += std::string(i ? "," : "") +
             R"({"type": "box", "center": [1.1, -2.2, 3.3], "size": [0.7, 0.3, 0.1]})";
  }
  return R"({"name": ")" + name + R"(", "description": ")" +
         std::string(kMaxSceneDescriptionBytes, 'd') + R"(", "obstacles": [)" + boxes +
         R"(], "params": {"particle_quantity": 10}})";
}

// A scene name of 4 MB made `dysa set` fail with RESOURCE_EXHAUSTED although the change was
// applied, and `dysa scenes` fail: every reply carries the name. Now what a scene keeps is
// bounded, and every reply of every RPC stays under the limit with the largest scene loaded.
TEST(ServerHostileInputTest, EveryReplyStaysUnderTheMessageLimit) {
  Fixture fx;
  Simulation::Stub& stub = fx.stub();
  v1::ControlReply control;
  v1::LoadSceneRequest load;
  load.set_json_text(std::string(R"({"name": ")") + std::string(4'190'000, 'N') + "\"}");
  ExpectRefused(stub.LoadScene(Context().get(), load, &control), "name: at most 256 bytes");

  load.set_json_text(LargestSceneText());
  ASSERT_TRUE(stub.LoadScene(Context().get(), load, &control).ok());
  EXPECT_LT(control.ByteSizeLong(), kMessageLimit);

  auto expect_small = [](const google::protobuf::Message& reply, const std::string& rpc) {
    EXPECT_LT(reply.ByteSizeLong(), kMessageLimit) << rpc;
  };
  v1::Status status;
  ASSERT_TRUE(stub.GetStatus(Context().get(), {}, &status).ok());
  expect_small(status, "GetStatus");
  EXPECT_EQ(status.scene().size(), 256u);
  v1::ParamsReply params;
  ASSERT_TRUE(stub.GetParams(Context().get(), {}, &params).ok());
  expect_small(params, "GetParams");
  v1::ListScenesReply scenes;
  ASSERT_TRUE(stub.ListScenes(Context().get(), {}, &scenes).ok());
  expect_small(scenes, "ListScenes");
  EXPECT_EQ(scenes.current(), status.scene());
  v1::SceneDescription scene;
  ASSERT_TRUE(stub.GetScene(Context().get(), {}, &scene).ok());
  expect_small(scene, "GetScene");
  EXPECT_EQ(scene.boxes_size(), int(kMaxObstacles));
  EXPECT_EQ(scene.description().size(), kMaxSceneDescriptionBytes);

  v1::StepRequest step;
  step.set_count(2);
  ASSERT_TRUE(stub.Step(Context().get(), step, &control).ok());
  expect_small(control, "Step");
  ASSERT_TRUE(stub.StepBack(Context().get(), {}, &control).ok());
  expect_small(control, "StepBack");
  ASSERT_TRUE(stub.Resume(Context().get(), {}, &control).ok());
  expect_small(control, "Resume");
  ASSERT_TRUE(stub.Pause(Context().get(), {}, &control).ok());
  expect_small(control, "Pause");
  ASSERT_TRUE(stub.Reset(Context().get(), {}, &control).ok());
  expect_small(control, "Reset");
  v1::UpdateParamsRequest update;
  (*update.mutable_params()->mutable_values())["viscosity"] = 0.002;
  v1::UpdateParamsReply updated;
  ASSERT_TRUE(stub.UpdateParams(Context().get(), update, &updated).ok());
  expect_small(updated, "UpdateParams");
  v1::StreamFramesRequest stream_request;
  auto stream_context = Context();
  auto reader = stub.StreamFrames(stream_context.get(), stream_request);
  v1::FrameMessage frame;
  ASSERT_TRUE(reader->Read(&frame));
  expect_small(frame, "StreamFrames");
  stream_context->TryCancel();
  reader->Finish();
}

// Every RPC argument a caller names things with, 3.9 MB long: the error names the field and
// quotes a bounded part (it came back as a metadata-size error), and nothing changes.
TEST(ServerHostileInputTest, ErrorsQuoteABoundedPartOfTheInput) {
  Fixture fx;
  Simulation::Stub& stub = fx.stub();
  const std::string huge(3'900'000, 'x');
  std::string accents;  // 2 bytes each, 3 on the wire each once percent-encoded
  while (accents.size() < 3'900'000) accents += "\xc3\xa9";
  v1::ControlReply control;

  v1::LoadSceneRequest load;
  load.set_json_text("{\"" + accents + "\": 1}");
  ExpectRefused(stub.LoadScene(Context().get(), load, &control), "unknown field");
  load.set_json_text("{\"params\": {\"" + huge + "\": 1}}");
  ExpectRefused(stub.LoadScene(Context().get(), load, &control), "params.xxxx");
  load.set_name(huge);
  ExpectRefused(stub.LoadScene(Context().get(), load, &control), "name: no built-in scene");
  load.set_name("seed_obstacles");
  load.set_solver(huge);
  ExpectRefused(stub.LoadScene(Context().get(), load, &control), "solver: unknown solver");

  v1::UpdateParamsRequest update;
  (*update.mutable_params()->mutable_values())[huge] = 1;
  v1::UpdateParamsReply updated;
  ExpectRefused(stub.UpdateParams(Context().get(), update, &updated), "unknown parameter");
  update.mutable_params()->mutable_values()->clear();
  (*update.mutable_params()->mutable_values())["viscosity"] = 0.5;
  update.mutable_update_mask()->add_paths(huge);
  ExpectRefused(stub.UpdateParams(Context().get(), update, &updated), "update_mask: 'xxx");

  const v1::Status status = GetStatus(stub);
  EXPECT_EQ(status.scene(), "seed_basic");
  EXPECT_EQ(status.particles(), 1000u);
}

// {"params":{"viscosity":1e999}} gave UNIMPLEMENTED with no message: the parser's exception
// escaped the handler.
TEST(ServerHostileInputTest, ANumberADoubleCannotHoldIsAnInvalidArgument) {
  Fixture fx;
  v1::LoadSceneRequest load;
  load.set_json_text(R"({"params": {"viscosity": 1e999}})");
  v1::ControlReply control;
  EXPECT_EQ(ExpectRefused(fx.stub().LoadScene(Context().get(), load, &control), "params.viscosity"),
            "scene: params.viscosity: 1e999 is out of the range of a double (at most 1.8e308 in "
            "magnitude)");
  load.set_json_text(R"({"params": {"viscosity": 1e-400}})");
  ExpectRefused(fx.stub().LoadScene(Context().get(), load, &control),
                "params.viscosity: 1e-400 is too close to 0");
  EXPECT_EQ(GetStatus(fx.stub()).scene(), "seed_basic");
}

// A scene name with a newline or an escape was written raw to the log, so a client could forge
// log lines; a NUL cut a message short.
TEST(ServerHostileInputTest, ControlCharactersNeitherReachTheLogNorCutMessages) {
  Fixture fx;
  v1::LoadSceneRequest load;
  load.set_json_text(
      R"({"name": "x\n2026-01-01T00:00:00.000Z dysa-server: stopped\u001b[2J\u0000tail"})");
  v1::ControlReply control;
  const std::string message =
      ExpectRefused(fx.stub().LoadScene(Context().get(), load, &control), "name: control");
  EXPECT_NE(message.find("x\\n2026-01-01T00:00:00.000Z dysa-server: stopped\\x1b[2J\\x00tail"),
            std::string::npos)
      << message;
  load.set_json_text(R"({"name": "ok"})");
  ASSERT_TRUE(fx.stub().LoadScene(Context().get(), load, &control).ok());
  ASSERT_TRUE(fx.stub().Reset(Context().get(), {}, &control).ok());
  const std::vector<std::string> log = fx.log();
  ASSERT_FALSE(log.empty());
  for (const std::string& line : log) {
    for (char c : line) EXPECT_FALSE(static_cast<unsigned char>(c) < 0x20) << line;
  }
}

// RFC 6750: the scheme is case-insensitive; "bearer T" was refused.
TEST(ServerHostileInputTest, TheBearerSchemeIsCaseInsensitive) {
  ServerOptions options;
  options.token = "s3cret";
  Fixture fx(options);
  v1::ControlReply reply;
  for (const char* authorization :
       {"Bearer s3cret", "bearer s3cret", "BEARER s3cret", "bEaReR s3cret", "Bearer  s3cret"}) {
    EXPECT_TRUE(fx.stub().Pause(Context(authorization).get(), {}, &reply).ok()) << authorization;
  }
  for (const char* authorization : {"Bearer wrong", "Basic s3cret", "Bearers3cret", "Bearer",
                                    "Bearer ", "s3cret", "Bearer s3cret ", "Bearer s3cre"}) {
    EXPECT_EQ(fx.stub().Pause(Context(authorization).get(), {}, &reply).error_code(),
              grpc::StatusCode::UNAUTHENTICATED)
        << authorization;
  }
}

}  // namespace
}  // namespace dysa::service
