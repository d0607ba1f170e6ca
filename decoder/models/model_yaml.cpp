#include "decoder/models/model_yaml.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "decoder/models/yaml_tree.hpp"

namespace modtap {
namespace {

std::string join_lines(const std::vector<std::string>& problems) {
  std::string text;
  for (const auto& p : problems) {
    if (!text.empty()) text += '\n';
    text += p;
  }
  return text;
}

// Collects problems with their line so that one run of `models check` reports them all.
class Problems {
 public:
  explicit Problems(std::string file) : file_(std::move(file)) {}
  void add(const YamlNode& at, const std::string& message) { add(at.line(), message); }
  void add(unsigned line, const std::string& message) {
    list_.push_back(line == 0 ? fmt::format("{}: {}", file_, message)
                              : fmt::format("{}:{}: {}", file_, line, message));
  }
  void throw_if_any() const {
    if (!list_.empty()) throw ModelError(list_);
  }

 private:
  std::string file_;
  std::vector<std::string> list_;
};

// A map's key as text, or a problem.
bool read_key(const YamlNode& key, Problems& problems) {
  if (key.is_scalar()) return true;
  problems.add(key, "a key must be text, not a list, a map or nothing");
  return false;
}

// Reads the fields of one YAML map, refusing keys it does not know (typos, misplaced keys) and
// keys written twice (which one would win is not what the writer meant to decide).
class MapReader {
 public:
  MapReader(const YamlNode& node, Problems& problems, std::initializer_list<std::string_view> keys)
      : node_(node) {
    if (!node.is_map()) {
      problems.add(node, "expected a map");
      return;
    }
    std::set<std::string_view> seen;
    for (const auto& [key, value] : node.entries()) {
      if (!read_key(key, problems)) continue;
      if (std::find(keys.begin(), keys.end(), key.text()) == keys.end())
        problems.add(key, fmt::format("unknown key '{}'", key.text()));
      else if (!seen.insert(key.text()).second)
        problems.add(key, fmt::format("'{}' is written twice", key.text()));
    }
  }
  const YamlNode& operator[](std::string_view key) const { return node_[key]; }

 private:
  const YamlNode& node_;
};

// Integers as the manuals write them: 10, 0x2502, or 2502H.
bool parse_integer(const std::string& text, int64_t& out) {
  std::string s = text;
  int base = 10;
  bool negative = false;
  if (!s.empty() && s[0] == '-') negative = true, s.erase(0, 1);
  if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
    base = 16;
    s.erase(0, 2);
  } else if (s.size() > 1 && (s.back() == 'H' || s.back() == 'h')) {
    base = 16;
    s.pop_back();
  }
  if (s.empty()) return false;
  uint64_t value = 0;
  const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value, base);
  if (error != std::errc() || end != s.data() + s.size() || value > INT64_MAX) return false;
  out = negative ? -static_cast<int64_t>(value) : static_cast<int64_t>(value);
  return true;
}

// What a node is, for a problem's message: its text, quoted, or its kind.
std::string what_is(const YamlNode& node) {
  switch (node.kind()) {
    case YamlNode::Kind::scalar:
      return fmt::format("'{}'", node.text());
    case YamlNode::Kind::sequence:
      return "a list";
    case YamlNode::Kind::map:
      return "a map";
    default:
      return "nothing";
  }
}

template <typename T>
bool read_integer(const YamlNode& node, Problems& problems, T& out, int64_t min, int64_t max) {
  int64_t value = 0;
  if (!node.is_scalar() || !parse_integer(node.text(), value)) {
    problems.add(node, fmt::format("expected an integer, got {}", what_is(node)));
    return false;
  }
  if (value < min || value > max) {
    problems.add(node, fmt::format("{} is outside {}..{}", value, min, max));
    return false;
  }
  out = static_cast<T>(value);
  return true;
}

// A number, or a ratio as the manuals write scales: "10/1024" for "1024 / 10V".
bool read_number(const YamlNode& node, Problems& problems, double& out) {
  int64_t integer = 0;
  if (node.is_scalar() && parse_integer(node.text(), integer)) {
    out = static_cast<double>(integer);
    return true;
  }
  if (const auto slash = node.is_scalar() ? node.text().find('/') : std::string::npos;
      slash != std::string::npos) {
    const std::string& text = node.text();
    char* end = nullptr;
    const double numerator = std::strtod(text.c_str(), &end);
    const bool numerator_whole = end == text.c_str() + slash;
    const double denominator = std::strtod(text.c_str() + slash + 1, &end);
    if (numerator_whole && *end == '\0' && denominator != 0 && std::isfinite(numerator) &&
        std::isfinite(denominator)) {
      out = numerator / denominator;
      return true;
    }
  }
  if (node.is_scalar() && !node.text().empty()) {
    const std::string& text = node.text();
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    if (end == text.c_str() + text.size() && std::isfinite(value)) {
      out = value;
      return true;
    }
  }
  problems.add(node, fmt::format("expected a number, got {}", what_is(node)));
  return false;
}

std::string read_text(const YamlNode& node, Problems& problems) {
  if (!node.is_scalar()) {
    problems.add(node, "expected text");
    return {};
  }
  return node.text();
}

template <typename Enum>
bool read_choice(const YamlNode& node, Problems& problems,
                 std::initializer_list<std::pair<const char*, Enum>> choices, Enum& out) {
  const std::string text = node.is_scalar() ? node.text() : "";
  std::string names;
  for (const auto& [name, value] : choices) {
    if (text == name) {
      out = value;
      return true;
    }
    if (!names.empty()) names += ", ";
    names += name;
  }
  problems.add(node, fmt::format("'{}' is not one of: {}", text, names));
  return false;
}

// A value of an enum whose names (EnumNames) are what a model file writes.
template <NamedEnum Enum>
bool read_named(const YamlNode& node, Problems& problems, Enum& out) {
  const std::string text = node.is_scalar() ? node.text() : "";
  if (const std::optional<Enum> value = enum_named<Enum>(text)) {
    out = *value;
    return true;
  }
  problems.add(
      node, fmt::format("'{}' is not one of: {}", text, fmt::join(EnumNames<Enum>::names, ", ")));
  return false;
}

std::shared_ptr<const EnumTable> read_enum(const YamlNode& node, Problems& problems) {
  auto table = std::make_shared<EnumTable>();
  if (!node.is_map()) {
    problems.add(node, "named values must be a map of value: text");
    return table;
  }
  for (const auto& [key, text] : node.entries()) {
    int64_t value = 0;
    if (read_integer(key, problems, value, INT32_MIN, UINT32_MAX))
      (*table)[value] = read_text(text, problems);
  }
  return table;
}

class ModelReader {
 public:
  ModelReader(DeviceModel& model, Problems& problems) : model_(model), problems_(problems) {}

  void read(const YamlNode& root) {
    MapReader map(
        root, problems_,
        {"model", "extends", "title", "source", "stations", "limits", "timeout", "turnaround",
         "exceptions", "enums", "groups", "alias", "identify", "registers", "parameters"});
    if (!root.is_map()) return;
    if (map["model"]) model_.name = read_text(map["model"], problems_);
    if (model_.name.empty()) problems_.add(root, "a model needs 'model: NAME'");
    if (map["title"]) model_.title = read_text(map["title"], problems_);
    if (map["source"]) model_.source = read_text(map["source"], problems_);
    if (map["stations"]) read_stations(map["stations"]);
    if (map["limits"]) read_limits(map["limits"]);
    if (map["timeout"]) read_timeout(map["timeout"]);
    if (map["turnaround"]) read_turnaround(map["turnaround"]);
    if (map["exceptions"]) read_exceptions(map["exceptions"]);
    if (map["enums"]) read_enums(map["enums"]);
    if (map["groups"]) read_groups(map["groups"]);
    if (map["alias"]) read_alias(map["alias"]);
    if (map["identify"]) read_identify(map["identify"]);
    if (map["registers"]) read_registers(map["registers"]);
    if (map["parameters"]) read_parameters(map["parameters"]);
  }

 private:
  void read_stations(const YamlNode& node) {
    if (!node.is_sequence() || node.items().size() != 2) {
      problems_.add(node, "stations must be [first, last]");
      return;
    }
    if (read_integer(node.items()[0], problems_, model_.station_min, 0, 255) &&
        read_integer(node.items()[1], problems_, model_.station_max, 0, 255) &&
        model_.station_min > model_.station_max)
      problems_.add(node, fmt::format("stations [{}, {}]: the first is above the last",
                                      model_.station_min, model_.station_max));
  }

  void read_word_limits(const YamlNode& node, WordLimits& limits) {
    MapReader map(node, problems_, {"read", "write"});
    if (map["read"]) read_integer(map["read"], problems_, limits.read, 1, 125);
    if (map["write"]) read_integer(map["write"], problems_, limits.write, 1, 123);
  }

  void read_limits(const YamlNode& node) {
    MapReader map(node, problems_, {"rtu", "ascii", "same_group_only"});
    if (map["rtu"]) read_word_limits(map["rtu"], model_.rtu_limits);
    if (map["ascii"]) read_word_limits(map["ascii"], model_.ascii_limits);
    if (map["same_group_only"]) model_.same_group_only = read_flag(map["same_group_only"]);
  }

  void read_timeout(const YamlNode& node) {
    MapReader map(node, problems_, {"response_ms", "retries"});
    unsigned ms = 0;
    if (map["response_ms"] && read_integer(map["response_ms"], problems_, ms, 1, 60'000))
      model_.response_timeout_ns = int64_t{ms} * 1'000'000;
    if (map["retries"]) read_integer(map["retries"], problems_, model_.retries.emplace(), 0, 100);
  }

  void read_turnaround(const YamlNode& node) {
    MapReader map(node, problems_, {"min_ms"});
    unsigned ms = 0;
    if (map["min_ms"] && read_integer(map["min_ms"], problems_, ms, 1, 10'000))
      model_.min_turnaround_ns = int64_t{ms} * 1'000'000;
  }

  // YAML 1.1's words for true and false, which is what libyaml reads.
  bool read_flag(const YamlNode& node) {
    static constexpr std::string_view yes[] = {"true", "True", "TRUE", "yes", "Yes", "YES",
                                               "y",    "Y",    "on",   "On",  "ON"};
    static constexpr std::string_view no[] = {"false", "False", "FALSE", "no",  "No", "NO",
                                              "n",     "N",     "off",   "Off", "OFF"};
    const auto is_one_of = [&](const auto& words) {
      return node.is_scalar() &&
             std::find(std::begin(words), std::end(words), node.text()) != std::end(words);
    };
    if (is_one_of(yes)) return true;
    if (!is_one_of(no)) problems_.add(node, "expected true or false");
    return false;
  }

  void read_exceptions(const YamlNode& node) {
    MapReader map(node, problems_, {"vendor", "codes"});
    if (map["vendor"]) model_.vendor_exceptions = read_flag(map["vendor"]);
    if (!map["codes"]) return;
    if (!map["codes"].is_map()) return problems_.add(map["codes"], "codes must be a map");
    model_.exceptions.clear();
    for (const auto& [key, text] : map["codes"].entries()) {
      uint8_t code = 0;
      if (read_integer(key, problems_, code, 1, 255))
        model_.exceptions[code] = read_text(text, problems_);
    }
  }

  void read_enums(const YamlNode& node) {
    if (!node.is_map()) return problems_.add(node, "enums must be a map of name: {value: text}");
    for (const auto& [key, values] : node.entries())
      if (read_key(key, problems_)) enums_[key.text()] = read_enum(values, problems_);
  }

  void read_groups(const YamlNode& node) {
    MapReader map(node, problems_,
                  {"prefix", "counts", "max_group", "max_index", "closed", "access"});
    ParameterGroups groups;
    if (map["prefix"]) groups.prefix = read_text(map["prefix"], problems_);
    if (map["max_group"]) read_integer(map["max_group"], problems_, groups.max_group, 0, 255);
    if (map["max_index"]) read_integer(map["max_index"], problems_, groups.max_index, 0, 255);
    if (map["access"]) read_access(map["access"], groups.access);
    if (const auto& counts = map["counts"]) {
      if (!counts.is_map()) return problems_.add(counts, "counts must be a map of group: count");
      for (const auto& [key, value] : counts.entries()) {
        unsigned group = 0, count = 0;
        if (read_integer(key, problems_, group, 0, 255) &&
            read_integer(value, problems_, count, 1, 256))
          groups.counts[group] = count;
      }
    }
    if (const auto& closed = map["closed"]; closed && !closed.is_sequence()) {
      problems_.add(closed, "closed must be a list of groups, as [3, 4]");
    } else if (closed) {
      for (const auto& item : closed.items()) {
        unsigned group = 0;
        if (read_integer(item, problems_, group, 0, 255)) groups.closed.insert(group);
      }
    }
    model_.groups = groups;
  }

  void read_alias(const YamlNode& node) {
    MapReader map(node, problems_, {"flag", "label"});
    WriteOnlyAlias alias;
    if (map["flag"]) read_integer(map["flag"], problems_, alias.flag, 1, 0xFFFF);
    if (map["label"]) alias.label = read_text(map["label"], problems_);
    model_.alias = alias;
  }

  void read_identify(const YamlNode& node) {
    MapReader map(node, problems_, {"address", "value"});
    Identification id;
    if (!map["address"] || !map["value"])
      return problems_.add(node, "identify needs address and value");
    read_integer(map["address"], problems_, id.address, 0, 0xFFFF);
    read_integer(map["value"], problems_, id.value, 0, 0xFFFF);
    model_.identification = id;
  }

  void read_access(const YamlNode& node, Access& access) {
    read_choice(node, problems_,
                {{"R", Access::read}, {"W", Access::write}, {"RW", Access::read_write}}, access);
  }

  void read_registers(const YamlNode& node) {
    if (!node.is_sequence()) return problems_.add(node, "registers must be a list");
    for (const auto& item : node.items()) read_register(item);
  }

  void read_register(const YamlNode& node) {
    MapReader map(
        node, problems_,
        {"address", "to", "table", "name", "label", "type", "words", "order", "scale", "offset",
         "unit", "access", "min", "max", "enum", "values", "bits", "reserved", "fault"});
    if (!node.is_map()) return;
    RegisterDef def;
    uint16_t last = 0;
    if (!map["address"]) return problems_.add(node, "a register needs an address");
    if (!read_integer(map["address"], problems_, def.address, 0, 0xFFFF)) return;
    last = def.address;
    if (map["reserved"]) def.reserved = read_flag(map["reserved"]);
    if (map["to"] && read_integer(map["to"], problems_, last, def.address, 0xFFFF) &&
        last != def.address && !def.reserved)
      problems_.add(map["to"], "'to' is for runs of reserved registers");
    if (map["table"])
      read_choice(map["table"], problems_,
                  {{"holding", Table::holding},
                   {"input", Table::input},
                   {"coil", Table::coil},
                   {"discrete", Table::discrete}},
                  def.table);
    if (map["name"]) def.name = read_text(map["name"], problems_);
    if (map["label"]) def.label = read_text(map["label"], problems_);
    if (map["type"]) read_named(map["type"], problems_, def.type);
    if (map["words"]) read_integer(map["words"], problems_, def.words, 1, 64);
    if (map["order"]) read_named(map["order"], problems_, def.order);
    if (map["scale"]) read_number(map["scale"], problems_, def.scale);
    if (map["offset"]) read_number(map["offset"], problems_, def.offset);
    if (map["unit"]) def.unit = read_text(map["unit"], problems_);
    if (map["access"]) read_access(map["access"], def.access);
    if (map["min"]) read_number(map["min"], problems_, def.min.emplace());
    if (map["max"]) read_number(map["max"], problems_, def.max.emplace());
    if (def.min && def.max && *def.min > *def.max)
      problems_.add(map["min"], fmt::format("min {:g} is above max {:g}", *def.min, *def.max));
    if (map["enum"] && map["values"])
      problems_.add(map["values"], "'enum' and 'values' both name the values: give one");
    if (map["enum"]) read_named_enum(map["enum"], def);
    if (map["values"]) def.values = read_enum(map["values"], problems_);
    if (map["bits"]) read_bits(map["bits"], def);
    if (map["fault"]) def.fault = read_flag(map["fault"]);
    if (def.name.empty() && !def.reserved) problems_.add(node, "a register needs a name");
    if (const uint16_t words = words_of_type(def.type)) {
      if (map["words"] && def.words != words)
        problems_.add(map["words"],
                      fmt::format("the type spans {} registers, not {}", words, def.words));
      def.words = words;
    }
    const bool number = def.type != ValueType::string && def.type != ValueType::raw;
    if (number && def.words > 4)
      problems_.add(map["words"], "a number spans at most 4 registers (64 bits): a string any");
    for (unsigned address = def.address; address <= last; ++address) {
      RegisterDef one = def;
      one.address = static_cast<uint16_t>(address);
      if (one.name.empty()) one.name = fmt::format("reserved_{:04X}", address);
      define(node, std::move(one));
    }
  }

  void read_named_enum(const YamlNode& node, RegisterDef& def) {
    const std::string name = read_text(node, problems_);
    if (auto it = enums_.find(name); it != enums_.end()) {
      def.values = it->second;
    } else {
      problems_.add(node, fmt::format("no enum named '{}' under 'enums'", name));
    }
  }

  void read_bits(const YamlNode& node, RegisterDef& def) {
    if (!node.is_sequence()) return problems_.add(node, "bits must be a list");
    for (const auto& item : node.items()) {
      MapReader map(item, problems_, {"bit", "bits", "name", "values"});
      BitField field;
      if (map["bit"]) {
        read_integer(map["bit"], problems_, field.lsb, 0, 31);
      } else if (const auto& range = map["bits"];
                 range.is_sequence() && range.items().size() == 2) {
        uint8_t high = 0;
        read_integer(range.items()[0], problems_, field.lsb, 0, 31);
        read_integer(range.items()[1], problems_, high, field.lsb, 31);
        field.width = static_cast<uint8_t>(high - field.lsb + 1);
      } else {
        problems_.add(item, "a bit field needs 'bit: N' or 'bits: [low, high]'");
        continue;
      }
      if (map["name"]) field.name = read_text(map["name"], problems_);
      if (field.name.empty()) problems_.add(item, "a bit field needs a name");
      if (const auto& values = map["values"]) {
        const auto table = read_enum(values, problems_);
        for (const auto& [value, text] : *table) field.values[static_cast<uint32_t>(value)] = text;
      }
      def.bits.push_back(std::move(field));
    }
  }

  // A table of address: parameter name, for models whose parameters follow no rule (N3).
  void read_parameters(const YamlNode& node) {
    if (!node.is_map()) return problems_.add(node, "parameters must be a map of address: name");
    for (const auto& [key, name] : node.entries()) {
      RegisterDef def;
      if (!read_integer(key, problems_, def.address, 0, 0xFFFF)) continue;
      def.name = read_text(name, problems_);
      define(key, std::move(def));
    }
  }

  // A register this file defines: once only (a model that extends another may redefine the
  // base's registers, but not its own).
  void define(const YamlNode& node, RegisterDef def) {
    const std::pair<Table, uint16_t> key{def.table, def.address};
    if (!defined_here_.insert(key).second)
      problems_.add(node,
                    fmt::format("{} {:04X}H is defined twice", to_string(def.table), def.address));
    model_.registers[key] = std::move(def);
  }

  DeviceModel& model_;
  Problems& problems_;
  std::map<std::string, std::shared_ptr<const EnumTable>> enums_;
  std::set<std::pair<Table, uint16_t>> defined_here_;
};

YamlNode load(std::string_view yaml, const std::string& file) {
  try {
    return parse_yaml(yaml);
  } catch (const YamlSyntaxError& e) {
    Problems problems(file);
    problems.add(e.line(), e.what());
    problems.throw_if_any();
    throw;
  }
}

}  // namespace

ModelError::ModelError(std::vector<std::string> problems)
    : std::runtime_error(join_lines(problems)), problems_(std::move(problems)) {}

struct ModelFile::Document {
  YamlNode root;
};

ModelFile::ModelFile(std::string_view yaml, std::string file)
    : document_(std::make_unique<Document>(Document{load(yaml, file)})), file_(std::move(file)) {
  const YamlNode& root = document_->root;
  if (root.is_map() && root["extends"] && root["extends"].is_scalar())
    base_ = root["extends"].text();
}

ModelFile::ModelFile(ModelFile&&) noexcept = default;
ModelFile& ModelFile::operator=(ModelFile&&) noexcept = default;
ModelFile::~ModelFile() = default;

DeviceModel ModelFile::model(const DeviceModel* base) const {
  const YamlNode& root = document_->root;
  Problems problems(file_);
  DeviceModel model = base ? *base : DeviceModel{};
  model.name.clear();
  model.title = base ? "based on " + base->name : "";
  if (root.is_map() && root["extends"] && !base)
    problems.add(root["extends"], "extends a model that is not loaded");
  ModelReader(model, problems).read(root);
  if (!root.is_map() && !root.is_null()) problems.add(root, "a model file must be a YAML map");
  problems.throw_if_any();
  return model;
}

std::string model_base(std::string_view yaml, const std::string& file) {
  return ModelFile(yaml, file).base();
}

DeviceModel parse_model(std::string_view yaml, const std::string& file, const DeviceModel* base) {
  return ModelFile(yaml, file).model(base);
}

}  // namespace modtap
