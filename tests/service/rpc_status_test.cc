// Tests of server/service/src/rpc_status.h: an exception in a handler becomes a status with a
// message (gRPC's own answer is UNIMPLEMENTED with none), and every message is bounded.
#include "rpc_status.h"

#include <gtest/gtest.h>

#include <new>
#include <optional>
#include <stdexcept>
#include <string>

#include "dysa/core/types.h"

namespace dysa::service {
namespace {

TEST(GuardedTest, ReturnsWhatTheBodyReturns) {
  EXPECT_FALSE(Guarded([]() -> std::optional<grpc::Status> { return std::nullopt; }));
  const std::optional<grpc::Status> ok = Guarded([] { return std::optional(grpc::Status::OK); });
  ASSERT_TRUE(ok);
  EXPECT_TRUE(ok->ok());
}

TEST(GuardedTest, AnExceptionBecomesAStatusWithAMessage) {
  const auto status_of = [](auto throwing) {
    return *Guarded([&]() -> std::optional<grpc::Status> {
      throwing();
      return std::nullopt;
    });
  };
  grpc::Status s = status_of([] { throw ConfigError("params.viscosity", "is wrong"); });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(s.error_message(), "params.viscosity: is wrong");
  s = status_of([] { throw std::runtime_error("the GPU fell over"); });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_EQ(s.error_message(), "internal error: the GPU fell over");
  s = status_of([] { throw std::bad_alloc(); });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_EQ(s.error_message(), "internal error: out of memory");
  s = status_of([] { throw 42; });
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_EQ(s.error_message(), "internal error: an unknown exception");
  s = status_of([] { throw std::runtime_error(std::string(1'000'000, 'x') + "\n"); });
  EXPECT_LE(s.error_message().size(), kMaxStatusMessageBytes);
}

TEST(BoundedStatusTest, BoundsAndEscapesTheMessageAndKeepsTheCode) {
  const grpc::Status s =
      BoundedStatus(grpc::StatusCode::INVALID_ARGUMENT, "a\nb" + std::string(10'000, 'z'));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_LE(s.error_message().size(), kMaxStatusMessageBytes);
  EXPECT_EQ(s.error_message().substr(0, 5), "a\\nbz");
  EXPECT_NE(s.error_message().find("(10003 bytes)"), std::string::npos);
  EXPECT_TRUE(BoundedStatus(grpc::Status::OK).ok());
  const grpc::Status short_one = BoundedStatus({grpc::StatusCode::UNAVAILABLE, "gone"});
  EXPECT_EQ(short_one.error_code(), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(short_one.error_message(), "gone");
}

}  // namespace
}  // namespace dysa::service
