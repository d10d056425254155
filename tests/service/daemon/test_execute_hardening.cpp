// The execute request parser on hostile requests (the cases tests/fuzz/fuzz_execute found):
// every refusal is an rv::Error, and what it accepts is read confined.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "daemon/server_execute.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/server_config.hpp"

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

TEST(ExecuteHardening, CompressionIsOneOfTheProfiles) {
  const json base = json::parse(R"({"inputs":{"resolution":10,"seeds":{"type":"FeatureCollection","features":[]}}})");
  EXPECT_EQ(parse_execution(base, kId, ServerConfig{}).spec.outputs.compression, Compression::fast);
  for (const Compression c : {Compression::fast, Compression::small, Compression::deflate, Compression::none}) {
    json body = base;
    body["inputs"]["compression"] = std::string(to_string(c));
    const Execution ex = parse_execution(body, kId, ServerConfig{});
    EXPECT_EQ(ex.spec.outputs.compression, c);
    EXPECT_EQ(ex.inputs_summary["compression"], to_string(c));
    body["inputs"]["compression"] = {{"value", std::string(to_string(c))}};  // a qualified value
    EXPECT_EQ(parse_execution(body, kId, ServerConfig{}).spec.outputs.compression, c);
  }
  for (const json& bad : {json("zip"), json("FAST"), json(""), json(3), json::array({"fast"})}) {
    json body = base;
    body["inputs"]["compression"] = bad;
    try {
      parse_execution(body, kId, ServerConfig{});
      ADD_FAILURE() << "accepted " << bad.dump();
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_argument);
      EXPECT_NE(std::string(e.what()).find("input 'compression'"), std::string::npos) << e.what();
    }
  }
}

TEST(ExecuteHardening, DeeplyNestedBodiesAreRefusedWhileParsing) {
  // 100000 levels overflowed the stack in dump() before the limit.
  const std::string deep = R"({"inputs":{"x":)" + std::string(100000, '[') + std::string(100000, ']') + "}}";
  try {
    parse_body_json(deep);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_argument);
    EXPECT_NE(std::string(e.what()).find("deeper than 64"), std::string::npos) << e.what();
  }
  const std::string ok = R"({"a":)" + std::string(60, '[') + std::string(60, ']') + "}";
  EXPECT_NO_THROW(parse_body_json(ok));
  EXPECT_THROW(parse_body_json("{not json"), Error);
}

}  // namespace
}  // namespace rv::daemon
