#include "decoder/protocol/findings.hpp"

#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace modtap {
namespace {

// A finding's name is how a filter, a statistic and a JSON reader find it: one name, one finding.
TEST(Findings, EachNameIsUniqueAndHasATitle) {
  std::set<std::string_view> names;
  for (const FindingInfo& f : finding_registry()) {
    EXPECT_TRUE(names.insert(f.name).second) << f.name;
    EXPECT_FALSE(f.title.empty()) << f.name;
  }
}

TEST(Findings, BitsNameTheirEntriesInTheRegistryOrder) {
  std::vector<std::string_view> named;
  for_each_frame_finding(finding_retry | finding_bad_check | finding_ambiguous_echo,
                         [&](size_t slot) { named.push_back(frame_findings()[slot].name); });
  EXPECT_THAT(named, ::testing::ElementsAre("bad-check", "retry", "ambiguous-echo"));
  EXPECT_EQ(to_string(RuleKind::reserved_write), "reserved-write");
  EXPECT_EQ(to_string(RuleKind::identified), "identified");
  EXPECT_EQ(finding_registry().size(), frame_finding_count + rule_kind_count);
}

TEST(Findings, TheOutputDocsNameEveryFinding) {
  std::ifstream file(std::string(MODTAP_SOURCE) + "/docs/output.md");
  ASSERT_TRUE(file) << "docs/output.md";
  std::stringstream docs;
  docs << file.rdbuf();
  for (const FindingInfo& f : finding_registry())
    EXPECT_NE(docs.str().find(std::string("`").append(f.name).append("`")), std::string::npos)
        << f.name;
}

}  // namespace
}  // namespace modtap
