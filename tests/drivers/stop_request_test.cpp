#include "drivers/stop_request.hpp"

#include <gtest/gtest.h>

#include <string>

namespace hapticd::drivers::stop_request_test {
namespace {

// The cause is kept by pointer. Before the first request it must read as ""
// and the first cause must be taken whatever the compiler does with equal
// string literals: clang under ASan keeps each "" apart, and the daemon
// logged "stopped by  during configure".
TEST(StopRequest, TheFirstCauseIsKeptAndReadBack) {
  StopRequest stop;
  EXPECT_FALSE(stop.requested());
  EXPECT_EQ(std::string(stop.why()), "");
  const std::string sigterm = "SIGTERM";  // not a literal: no merging can help
  stop.request(sigterm.c_str());
  stop.request("SIGINT");
  EXPECT_TRUE(stop.requested());
  EXPECT_TRUE(stop.token().stop_requested());
  EXPECT_EQ(stop.why(), sigterm.c_str());
}

}  // namespace
}  // namespace hapticd::drivers::stop_request_test
