// The execute request parser on hostile requests (the cases tests/fuzz/fuzz_execute found):
// every refusal is an rv::Error, and what it accepts is read confined.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "rv/error.hpp"
#include "rv/server_config.hpp"
#include "server_execute.hpp"

namespace rv::daemon {
namespace {

using nlohmann::json;

const char* kId = "00112233445566778899aabbccddeeff";

ErrorKind kind_of(const json& body) {
  try {
    parse_execution(body, kId, ServerConfig{});
  } catch (const Error& e) {
    return e.kind();
  }
  ADD_FAILURE() << "accepted: " << body.dump();
  return ErrorKind::internal;
}

TEST(ExecuteHardening, MembersOfTheWrongTypeAreRvErrors) {
  // json::value("type", "") threw nlohmann's type_error for these.
  EXPECT_EQ(kind_of(json::parse(R"({"inputs":{"seeds":{"type":5,"value":[1,2]},"resolution":1}})")),
            ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of(json::parse(R"({"inputs":{"seeds":{"value":[1],"mediaType":7},"resolution":1}})")),
            ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of(json::parse(R"({"inputs":{"seeds":{"value":"eA==","mediaType":"application/flatgeobuf",)"
                                R"("encoding":false},"resolution":1}})")),
            ErrorKind::invalid_argument);
}

TEST(ExecuteHardening, UploadsAreReadConfined) {
  const json body = json::parse(R"({"inputs":{"resolution":10,"seeds":{"type":"FeatureCollection","features":[]}}})");
  const Execution ex = parse_execution(body, kId, ServerConfig{});
  EXPECT_TRUE(ex.spec.seeds.confined);
  ASSERT_EQ(ex.spec.seeds.paths.size(), 1u);
  EXPECT_EQ(ex.spec.seeds.paths[0].rfind("/vsimem/", 0), 0u) << ex.spec.seeds.paths[0];
}

}  // namespace
}  // namespace rv::daemon
