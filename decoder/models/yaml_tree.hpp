// A YAML document read into a tree whose every node knows its line, through libyaml.
//
// Only what model files need: maps, sequences and scalars as text (no implicit typing: the
// reader decides what a scalar means), anchors and aliases expanded, the first document of a
// stream. libyaml's parser, not yaml-cpp's, because reading the built-in models was a third
// of a short run's time (docs/performance.md).
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace modtap {

class YamlNode {
 public:
  enum class Kind : unsigned char { absent, null, scalar, sequence, map };
  using Entry = std::pair<YamlNode, YamlNode>;

  YamlNode() = default;
  YamlNode(Kind kind, unsigned line) : kind_(kind), line_(line) {}

  Kind kind() const { return kind_; }
  // Absent: a key the map does not have. Every other node, null included, is present.
  explicit operator bool() const { return kind_ != Kind::absent; }
  bool is_null() const { return kind_ == Kind::null; }
  bool is_scalar() const { return kind_ == Kind::scalar; }
  bool is_sequence() const { return kind_ == Kind::sequence; }
  bool is_map() const { return kind_ == Kind::map; }

  // 1-based; 0 for an absent node.
  unsigned line() const { return line_; }
  // A scalar's text, as written (without quotes).
  const std::string& text() const { return text_; }
  // A sequence's items.
  const std::vector<YamlNode>& items() const { return items_; }
  // A map's keys and values, in the order written.
  const std::vector<Entry>& entries() const { return entries_; }
  // The value of the first scalar key equal to `key`, or an absent node.
  const YamlNode& operator[](std::string_view key) const;

 private:
  friend class YamlBuilder;

  Kind kind_ = Kind::absent;
  unsigned line_ = 0;
  std::string text_;
  std::vector<YamlNode> items_;
  std::vector<Entry> entries_;
};

// Text that is not YAML, at a line (1-based; 0 when the parser gives none).
class YamlSyntaxError : public std::runtime_error {
 public:
  YamlSyntaxError(unsigned line, const std::string& message)
      : std::runtime_error(message), line_(line) {}
  unsigned line() const { return line_; }

 private:
  unsigned line_;
};

// The first document of `text` (a null node for an empty text). Throws YamlSyntaxError, also
// for nesting deeper than 64 levels and aliases that expand past 100,000 nodes (a model has a few
// thousand).
YamlNode parse_yaml(std::string_view text);

}  // namespace modtap
