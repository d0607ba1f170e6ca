#include "decoder/protocol/field_registry.hpp"

#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

namespace modtap {
namespace {

// A filter or a JSON reader that meets a name must know what it holds: two fields may share a
// name (FC05's value prints in hex, FC06's in decimal) only when JSON gives them alike.
TEST(FieldRegistry, FieldsSharingANameShareTheirJsonKind) {
  std::map<std::string_view, FieldType> seen;
  for (const FieldInfo& f : field_registry()) {
    if (f.item) continue;  // an item's key lives inside its list's objects
    const auto [it, added] = seen.emplace(f.name, f.type);
    if (!added) {
      EXPECT_EQ(json_kind(it->second), json_kind(f.type)) << f.name;
    }
  }
}

TEST(FieldRegistry, EveryFieldHasANameAndATitle) {
  for (const FieldInfo& f : field_registry()) {
    EXPECT_FALSE(f.name.empty());
    EXPECT_FALSE(f.title.empty()) << f.name;
    EXPECT_EQ(&field_info(f.id), &f);
  }
}

// docs/output.md is where a user looks a key up: every field's name is there.
TEST(FieldRegistry, TheOutputDocsNameEveryField) {
  std::ifstream file(std::string(MODTAP_SOURCE) + "/docs/output.md");
  ASSERT_TRUE(file) << "docs/output.md";
  std::stringstream docs;
  docs << file.rdbuf();
  for (const FieldInfo& f : field_registry())
    EXPECT_NE(docs.str().find(std::string("`").append(f.name).append("`")), std::string::npos)
        << f.name;
}

}  // namespace
}  // namespace modtap
