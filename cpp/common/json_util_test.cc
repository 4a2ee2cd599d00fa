#include "common/json_util.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <functional>

#include "common/atomic_file.h"
#include "common/error.h"

namespace mound {
namespace {

std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(JsonUtilTest, SyntaxErrorNamesLineAndKey) {
  const std::string text = "{\n  \"sites\": [\n    {\"id\": \"a\", \"reward\": NaN}\n  ]\n}\n";
  const std::string msg = MessageOf([&] { ParseJson(text, "s.json"); });
  EXPECT_NE(msg.find("s.json:3:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("\"reward\""), std::string::npos) << msg;
  EXPECT_NE(msg.find("NaN"), std::string::npos) << msg;
}

TEST(JsonUtilTest, FieldAccessorsNameTheField) {
  const nlohmann::json j = nlohmann::json::parse(R"({"a": -1, "b": "x"})");
  EXPECT_NE(
      MessageOf([&] { RequireNonNegative(j, "a", "sites[2]"); }).find("sites[2].a: must be >= 0"),
      std::string::npos);
  EXPECT_NE(MessageOf([&] { RequireFinite(j, "b", ""); }).find("b: must be a number"),
            std::string::npos);
  EXPECT_NE(MessageOf([&] { RequireFinite(j, "zz", "home"); }).find("home.zz: missing"),
            std::string::npos);
  EXPECT_FALSE(OptionalNonNegative(j, "missing", "").has_value());
  EXPECT_NE(MessageOf([&] { ParseJson(R"({"c": 1e400})", "big.json"); }).find("big.json"),
            std::string::npos);
}

TEST(JsonUtilTest, SchemaAndVersionAreChecked) {
  const auto ok = nlohmann::json::parse(R"({"schema": "mound.sites", "version": 1})");
  EXPECT_EQ(CheckSchema(ok, "mound.sites", 1, "f"), 1);
  const auto v2 = nlohmann::json::parse(R"({"schema": "mound.sites", "version": 2})");
  EXPECT_NE(MessageOf([&] { CheckSchema(v2, "mound.sites", 1, "f"); }).find("version"),
            std::string::npos);
  const auto vs = nlohmann::json::parse(R"({"schema": "mound.sites", "version": "1"})");
  EXPECT_NE(MessageOf([&] { CheckSchema(vs, "mound.sites", 1, "f"); }).find("version"),
            std::string::npos);
}

TEST(AtomicFileTest, WritesAndLeavesNoTemporary) {
  const std::string path = ::testing::TempDir() + "/atomic_test.json";
  WriteFileAtomic(path, "first");
  WriteFileAtomic(path, "second");
  EXPECT_EQ(ReadFile(path), "second");
  EXPECT_THROW(WriteFileAtomic("/nonexistent-dir/x.json", "x"), InputError);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace mound
