#include "decoder/models/yaml_tree.hpp"

#include <map>

#include <fmt/format.h>
#include <yaml.h>

namespace modtap {

const YamlNode& YamlNode::operator[](std::string_view key) const {
  static const YamlNode absent;
  for (const auto& [k, v] : entries_)
    if (k.is_scalar() && k.text() == key) return v;
  return absent;
}

// Builds the tree from libyaml's events, one node per call of `node`.
class YamlBuilder {
 public:
  explicit YamlBuilder(std::string_view text) {
    if (!yaml_parser_initialize(&parser_)) throw YamlSyntaxError(0, "out of memory");
    // libyaml asserts on a null pointer, which an empty view may hold.
    static const unsigned char nothing = 0;
    const auto* bytes =
        text.empty() ? &nothing : reinterpret_cast<const unsigned char*>(text.data());
    yaml_parser_set_input_string(&parser_, bytes, text.size());
  }
  ~YamlBuilder() {
    release_event();
    yaml_parser_delete(&parser_);
  }
  YamlBuilder(const YamlBuilder&) = delete;
  YamlBuilder& operator=(const YamlBuilder&) = delete;

  YamlNode document() {
    next();  // the stream's start
    if (next().type != YAML_DOCUMENT_START_EVENT) return YamlNode(YamlNode::Kind::null, 1);
    next();
    YamlNode root = node(0);
    next();  // the document's end: a syntax error before it is still an error
    return root;
  }

 private:
  static constexpr unsigned max_depth = 64;
  static constexpr size_t max_nodes = 100'000;

  const yaml_event_t& next() {
    release_event();
    if (!yaml_parser_parse(&parser_, &event_)) {
      const std::string context = parser_.context ? fmt::format(" ({})", parser_.context) : "";
      throw YamlSyntaxError(
          static_cast<unsigned>(parser_.problem_mark.line) + 1,
          fmt::format("{}{}", parser_.problem ? parser_.problem : "not YAML", context));
    }
    has_event_ = true;
    return event_;
  }

  void release_event() {
    if (has_event_) yaml_event_delete(&event_);
    has_event_ = false;
  }

  unsigned line() const { return static_cast<unsigned>(event_.start_mark.line) + 1; }

  // The node whose first event is the current one; leaves its last event current.
  YamlNode node(unsigned depth) {
    if (depth > max_depth)
      throw YamlSyntaxError(line(), fmt::format("nested deeper than {} levels", max_depth));
    count(1);
    switch (event_.type) {
      case YAML_SCALAR_EVENT:
        return anchored(event_.data.scalar.anchor, scalar());
      case YAML_SEQUENCE_START_EVENT: {
        const std::string anchor = name(event_.data.sequence_start.anchor);
        YamlNode seq(YamlNode::Kind::sequence, line());
        while (next().type != YAML_SEQUENCE_END_EVENT) seq.items_.push_back(node(depth + 1));
        return anchored(anchor, std::move(seq));
      }
      case YAML_MAPPING_START_EVENT: {
        const std::string anchor = name(event_.data.mapping_start.anchor);
        YamlNode map(YamlNode::Kind::map, line());
        while (next().type != YAML_MAPPING_END_EVENT) {
          YamlNode key = node(depth + 1);
          next();
          map.entries_.emplace_back(std::move(key), node(depth + 1));
        }
        return anchored(anchor, std::move(map));
      }
      case YAML_ALIAS_EVENT:
        return alias();
      default:
        throw YamlSyntaxError(line(), "unexpected YAML event");
    }
  }

  YamlNode scalar() const {
    const auto& s = event_.data.scalar;
    std::string text(reinterpret_cast<const char*>(s.value), s.length);
    // YAML's nulls, when not quoted: `key:`, `~`, `null`.
    const bool null =
        s.style == YAML_PLAIN_SCALAR_STYLE &&
        (text.empty() || text == "~" || text == "null" || text == "Null" || text == "NULL");
    YamlNode out(null ? YamlNode::Kind::null : YamlNode::Kind::scalar, line());
    if (!null) out.text_ = std::move(text);
    return out;
  }

  static std::string name(const yaml_char_t* anchor) {
    return anchor ? reinterpret_cast<const char*>(anchor) : "";
  }

  YamlNode anchored(const std::string& anchor, YamlNode node) {
    if (!anchor.empty()) anchors_[anchor] = {node, size(node)};
    return node;
  }
  YamlNode anchored(const yaml_char_t* anchor, YamlNode node) {
    return anchored(name(anchor), std::move(node));
  }

  // An alias is a copy of its anchor's node, counted whole so that aliases of aliases cannot
  // grow the tree without bound.
  YamlNode alias() {
    const auto it = anchors_.find(name(event_.data.alias.anchor));
    if (it == anchors_.end())
      throw YamlSyntaxError(line(),
                            fmt::format("no anchor named '{}'", name(event_.data.alias.anchor)));
    count(it->second.second);
    return it->second.first;
  }

  void count(size_t nodes) {
    nodes_ += nodes;
    if (nodes_ > max_nodes)
      throw YamlSyntaxError(line(), fmt::format("more than {} nodes", max_nodes));
  }

  static size_t size(const YamlNode& n) {
    size_t total = 1;
    for (const auto& item : n.items()) total += size(item);
    for (const auto& [k, v] : n.entries()) total += size(k) + size(v);
    return total;
  }

  yaml_parser_t parser_{};
  yaml_event_t event_{};
  bool has_event_ = false;
  std::map<std::string, std::pair<YamlNode, size_t>> anchors_;
  size_t nodes_ = 0;
};

YamlNode parse_yaml(std::string_view text) {
  return YamlBuilder(text).document();
}

}  // namespace modtap
