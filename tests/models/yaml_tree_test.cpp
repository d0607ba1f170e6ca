#include "decoder/models/yaml_tree.hpp"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace modtap {
namespace {

using ::testing::HasSubstr;

TEST(YamlTree, ReadsMapsListsAndScalarsWithTheirLines) {
  const YamlNode root = parse_yaml(
      "model: x\n"
      "stations: [1, 247]\n"
      "registers:\n"
      "  - {address: 0x2502, name: 'f'}\n"
      "  - address: 2503H\n"
      "    unit: \"Hz\"\n");
  ASSERT_TRUE(root.is_map());
  EXPECT_EQ(root["model"].text(), "x");
  EXPECT_EQ(root["model"].line(), 1u);
  ASSERT_TRUE(root["stations"].is_sequence());
  EXPECT_EQ(root["stations"].items()[1].text(), "247");
  const auto& registers = root["registers"].items();
  ASSERT_EQ(registers.size(), 2u);
  EXPECT_EQ(registers[0]["address"].text(), "0x2502");  // text: the reader decides the meaning
  EXPECT_EQ(registers[0]["name"].line(), 4u);
  EXPECT_EQ(registers[1]["address"].line(), 5u);
  EXPECT_EQ(registers[1]["unit"].text(), "Hz");
  EXPECT_FALSE(root["nothing"]);
  EXPECT_EQ(root["nothing"].line(), 0u);
}

TEST(YamlTree, NullsAreThoseNotQuoted) {
  const YamlNode root = parse_yaml("a:\nb: ~\nc: null\nd: 'null'\ne: \"\"\n");
  EXPECT_TRUE(root["a"].is_null());
  EXPECT_TRUE(root["a"]);  // present, with nothing in it
  EXPECT_TRUE(root["b"].is_null());
  EXPECT_TRUE(root["c"].is_null());
  EXPECT_EQ(root["d"].text(), "null");
  EXPECT_TRUE(root["e"].is_scalar());
  EXPECT_TRUE(parse_yaml("").is_null());
  EXPECT_TRUE(parse_yaml(std::string_view()).is_null());  // no text at all, not even a pointer
  EXPECT_TRUE(parse_yaml("# only a comment\n").is_null());
}

TEST(YamlTree, AliasesAreCopiesOfTheirAnchors) {
  const YamlNode root = parse_yaml("on_off: &states {0: off, 1: on}\nrun: *states\n");
  ASSERT_TRUE(root["run"].is_map());
  EXPECT_EQ(root["run"]["1"].text(), "on");
  EXPECT_EQ(root["run"].line(), 1u);  // where it was written
}

TEST(YamlTree, OnlyTheFirstDocumentIsRead) {
  EXPECT_EQ(parse_yaml("---\na: 1\n---\na: 2\n")["a"].text(), "1");
}

TEST(YamlTree, SyntaxErrorsSayTheLine) {
  try {
    parse_yaml("a: 1\nb: [1, 2\nc: 3\n");
    FAIL() << "no error";
  } catch (const YamlSyntaxError& e) {
    EXPECT_GE(e.line(), 2u);
    EXPECT_THAT(e.what(), HasSubstr("flow sequence"));
  }
  EXPECT_THROW(parse_yaml("a: *nowhere\n"), YamlSyntaxError);
  EXPECT_THROW(parse_yaml("a: 1\n a: 2\n"), YamlSyntaxError);
}

// Input that would take the reader's stack or memory without bound is refused.
TEST(YamlTree, DeepNestingAndAliasBombsAreRefused) {
  EXPECT_THROW(parse_yaml(std::string(10'000, '[')), YamlSyntaxError);
  std::string bomb = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n";
  for (char c = 'b'; c <= 'h'; ++c) {
    bomb += fmt::format("{0}: &{0} [", c);
    for (int i = 0; i < 10; ++i) bomb += fmt::format("*{}, ", static_cast<char>(c - 1));
    bomb += "]\n";
  }
  try {
    parse_yaml(bomb);
    FAIL() << "no error";
  } catch (const YamlSyntaxError& e) {
    EXPECT_THAT(e.what(), HasSubstr("nodes"));
  }
}

}  // namespace
}  // namespace modtap
