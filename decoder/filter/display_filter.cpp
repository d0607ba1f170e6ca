#include "decoder/filter/display_filter.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <memory>
#include <optional>
#include <regex>

#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "decoder/models/record_fields.hpp"
#include "decoder/models/register_meaning.hpp"
#include "decoder/protocol/field_registry.hpp"
#include "decoder/protocol/findings.hpp"
#include "decoder/protocol/function_codes.hpp"
#include "decoder/protocol/nearest_name.hpp"
#include "decoder/protocol/number_text.hpp"

namespace modtap {

FilterError::FilterError(size_t column, const std::string& message)
    : std::runtime_error(fmt::format("column {}: {}", column, message)), column_(column) {}

enum class Op : uint8_t { eq, ne, lt, le, gt, ge, contains, matches, in };
enum class NameKind : uint8_t { field, finding, register_attribute, register_named };
enum class RegisterAttribute : uint8_t { name, addr, value, raw, unit, text };

struct Name {
  NameKind kind = NameKind::field;
  std::vector<FieldId> ids;  // a field: every field the name stands for (FC05's and FC06's value)
  size_t finding = 0;        // a finding: its registry slot
  RegisterAttribute attribute = RegisterAttribute::value;
  std::string register_name;
};

struct Literal {
  bool is_number = false;
  double number = 0;
  std::string text{};
  std::optional<double> upto{};  // a range in a set, number..upto
};

struct FilterNode {
  enum class Kind : uint8_t { any_of, all_of, negation, presence, comparison } kind;
  size_t left = 0, right = 0;
  Name name{};
  Op op = Op::eq;
  Literal literal{};
  std::vector<Literal> set{};                   // `in {...}`
  std::shared_ptr<const std::regex> pattern{};  // `matches`
};

namespace {

// One value a name has on a record: a number, a text, or both (a register with a meaning).
struct Value {
  bool has_number = false;
  double number = 0;
  bool has_text = false;
  std::string_view text;
};

Value number(double n) {
  return {true, n, false, {}};
}
Value text(std::string_view t) {
  return {false, 0, true, t};
}

bool equal_ignoring_case(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

template <typename T>
bool ordered(Op op, const T& a, const T& b) {
  switch (op) {
    case Op::contains:
    case Op::matches:
    case Op::in:
      return false;
    case Op::eq:
      return a == b;
    case Op::ne:
      return a != b;
    case Op::lt:
      return a < b;
    case Op::le:
      return a <= b;
    case Op::gt:
      return a > b;
    case Op::ge:
      return a >= b;
  }
  return false;
}

bool contains_ignoring_case(std::string_view text, std::string_view part) {
  return std::search(text.begin(), text.end(), part.begin(), part.end(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         }) != text.end();
}

// `==` for one value; `!=` is handled as the negation of `==` over all values.
bool compare(const Value& v, Op op, const Literal& literal) {
  if (literal.upto) return v.has_number && v.number >= literal.number && v.number <= *literal.upto;
  if (literal.is_number) return v.has_number && ordered(op, v.number, literal.number);
  if (!v.has_text) return false;
  if (op == Op::eq) return equal_ignoring_case(v.text, literal.text);
  return ordered(op, v.text, std::string_view(literal.text));
}

bool compare(const Value& v, const FilterNode& node) {
  switch (node.op) {
    case Op::contains:
      return v.has_text && contains_ignoring_case(v.text, node.literal.text);
    case Op::matches:
      return v.has_text && std::regex_search(v.text.begin(), v.text.end(), *node.pattern);
    case Op::in:
      return std::any_of(node.set.begin(), node.set.end(),
                         [&](const Literal& member) { return compare(v, Op::eq, member); });
    case Op::ne:
      return compare(v, Op::eq, node.literal);
    default:
      return compare(v, node.op, node.literal);
  }
}

// ---- Parsing ----------------------------------------------------------------------------

struct Token {
  enum class Kind : uint8_t {
    name,
    number,
    string,
    op,
    open,
    close,
    open_set,
    close_set,
    comma,
    range,
    both,
    either,
    negate,
    end
  };
  Kind kind = Kind::end;
  size_t column = 0;  // from 1
  std::string text;
  double number = 0;
  Op op = Op::eq;
};

bool is_name_start(char c) {
  return std::isalpha(static_cast<unsigned char>(c)) || c == '_';
}
bool is_name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-';
}

class Lexer {
 public:
  explicit Lexer(std::string_view text) : text_(text) {}

  Token next() {
    while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) ++at_;
    Token t;
    t.column = at_ + 1;
    if (at_ >= text_.size()) return t;
    const char c = text_[at_];
    auto two = [&](const char* s) { return text_.substr(at_, 2) == s; };
    auto symbol = [&](Token::Kind kind, size_t length) {
      t.kind = kind;
      t.text = std::string(text_.substr(at_, length));
      at_ += length;
      return t;
    };
    auto op = [&](Op o, size_t length) {
      t.op = o;
      return symbol(Token::Kind::op, length);
    };
    if (two("==")) return op(Op::eq, 2);
    if (two("!=")) return op(Op::ne, 2);
    if (two("<=")) return op(Op::le, 2);
    if (two(">=")) return op(Op::ge, 2);
    if (c == '<') return op(Op::lt, 1);
    if (c == '>') return op(Op::gt, 1);
    if (two("&&")) return symbol(Token::Kind::both, 2);
    if (two("||")) return symbol(Token::Kind::either, 2);
    if (c == '!') return symbol(Token::Kind::negate, 1);
    if (c == '(') return symbol(Token::Kind::open, 1);
    if (c == ')') return symbol(Token::Kind::close, 1);
    if (c == '{') return symbol(Token::Kind::open_set, 1);
    if (c == '}') return symbol(Token::Kind::close_set, 1);
    if (c == ',') return symbol(Token::Kind::comma, 1);
    if (two("..")) return symbol(Token::Kind::range, 2);
    if (c == '~') return op(Op::matches, 1);
    if (c == '"') return string(t);
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '.') return numeric(t);
    if (is_name_start(c)) return word(t);
    throw FilterError(t.column, fmt::format("unexpected '{}'", c));
  }

 private:
  Token string(Token& t) {
    ++at_;
    while (at_ < text_.size() && text_[at_] != '"') {
      if (text_[at_] == '\\' && at_ + 1 < text_.size()) ++at_;
      t.text += text_[at_++];
    }
    if (at_ >= text_.size()) throw FilterError(t.column, "a string with no closing quote");
    ++at_;
    t.kind = Token::Kind::string;
    return t;
  }

  // 42, -1.5, 0x2502, 2502H.
  Token numeric(Token& t) {
    const size_t start = at_;
    if (text_[at_] == '-') ++at_;
    while (at_ < text_.size() &&
           (std::isalnum(static_cast<unsigned char>(text_[at_])) ||
            (text_[at_] == '.' && text_.substr(at_, 2) != "..")))  // 1..10 is a range
      ++at_;
    const std::string_view word = text_.substr(start, at_ - start);
    t.kind = Token::Kind::number;
    t.text = std::string(word);
    if (auto whole = parse_written_number(word)) {
      t.number = static_cast<double>(*whole);
      return t;
    }
    const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), t.number);
    if (error == std::errc() && end == word.data() + word.size() && std::isfinite(t.number))
      return t;
    throw FilterError(t.column, fmt::format("\"{}\" is not a number", word));
  }

  Token word(Token& t) {
    const size_t start = at_;
    while (at_ < text_.size() && is_name_char(text_[at_])) ++at_;
    t.text = std::string(text_.substr(start, at_ - start));
    static constexpr std::pair<const char*, Op> word_ops[] = {{"eq", Op::eq},
                                                              {"ne", Op::ne},
                                                              {"lt", Op::lt},
                                                              {"le", Op::le},
                                                              {"gt", Op::gt},
                                                              {"ge", Op::ge},
                                                              {"contains", Op::contains},
                                                              {"matches", Op::matches},
                                                              {"in", Op::in}};
    for (const auto& [name, op] : word_ops)
      if (t.text == name) {
        t.kind = Token::Kind::op;
        t.op = op;
        return t;
      }
    t.kind = t.text == "and"   ? Token::Kind::both
             : t.text == "or"  ? Token::Kind::either
             : t.text == "not" ? Token::Kind::negate
                               : Token::Kind::name;
    return t;
  }

  std::string_view text_;
  size_t at_ = 0;
};

constexpr std::string_view register_prefix = "register.";

template <typename Enum>
constexpr auto names_of() {
  return std::vector<std::string_view>(EnumNames<Enum>::names.begin(),
                                       EnumNames<Enum>::names.end());
}

// The fields whose values are a fixed set, and the other words the outputs use for them.
struct FixedValues {
  FieldId id;
  std::vector<std::string_view> values;
  std::vector<std::pair<std::string_view, std::string_view>> aliases;
};
const std::vector<FixedValues> fixed_values = [] {
  std::vector<std::string_view> reasons = names_of<NoiseReason>();
  for (std::string_view reason : EnumNames<TimeoutReason>::names) reasons.push_back(reason);
  std::vector<std::string_view> damages = names_of<Damage>();
  damages.erase(damages.begin());  // none: a frame without damage has no damage field
  return std::vector<FixedValues>{
      {FieldId::type, {"frame", "noise", "timeout", "unanswered"}, {}},
      {FieldId::role, names_of<Role>(), {{"req", "request"}, {"rsp", "response"}}},
      {FieldId::mode, names_of<Mode>(), {}},
      {FieldId::check, {"ok", "bad"}, {}},
      {FieldId::damage, damages, {}},
      {FieldId::reason, reasons, {}},
  };
}();

// "request, response or unknown".
std::string one_of(const std::vector<std::string_view>& values) {
  std::string text;
  for (size_t i = 0; i < values.size(); ++i)
    text += fmt::format("{}{}", i == 0 ? "" : i + 1 == values.size() ? " or " : ", ", values[i]);
  return text;
}

// Names people bring from Wireshark's Modbus dissector or from the outputs' words, and what
// modtap calls them.
constexpr std::pair<std::string_view, std::string_view> familiar_names[] = {
    {"modbus.func_code", "fc"},
    {"mbrtu.unit_id", "slave"},
    {"modbus.exception_code", "exception"},
    {"modbus.reference_num", "address"},
    {"modbus.word_cnt", "quantity"},
    {"modbus.bit_cnt", "quantity"},
    {"modbus.byte_cnt", "byte_count"},
    {"crc", "check"},
    {"lrc", "check"},
    {"timeout", "type == \"timeout\""},
    {"noise", "type == \"noise\""},
    {"request", "role == request"},
    {"response", "role == response"},
};

// What an unknown name likely meant: a familiar name's modtap name, a field it begins, or the
// nearest field or finding.
std::string suggestion(std::string_view word) {
  for (const auto& [familiar, ours] : familiar_names)
    if (word == familiar) return fmt::format("; modtap calls it {}", ours);
  NearestName nearest(word);
  for (const FieldInfo& field : field_registry()) {
    if (field.name.starts_with(word)) return fmt::format("; did you mean {}?", field.name);
    nearest.consider(field.name);
  }
  for (const FindingInfo& finding : finding_registry()) nearest.consider(finding.name);
  if (nearest.best()) return nearest.suggestion();
  return " (docs/output.md lists the names; register names need their --model)";
}

class Parser {
 public:
  Parser(std::string_view text, const std::function<bool(std::string_view)>& is_register_name,
         RegisterBase base, std::vector<FilterNode>& nodes)
      : lexer_(text), is_register_name_(is_register_name), base_(base), nodes_(nodes) {
    advance();
  }

  void parse() {
    nodes_.emplace_back();  // the root, filled once the whole text is read
    depth_.push_back(0);
    if (token_.kind == Token::Kind::end) throw FilterError(token_.column, "an empty filter");
    const size_t root = either();
    if (token_.kind != Token::Kind::end)
      throw FilterError(token_.column, fmt::format("unexpected \"{}\"", token_.text));
    nodes_[0] = nodes_[root];
  }

 private:
  void advance() { token_ = lexer_.next(); }

  // Evaluation recurses as deep as the tree: a filter deeper than a person writes is refused
  // before it can exhaust the stack.
  static constexpr size_t max_depth = 256;

  size_t add(FilterNode node) {
    size_t depth = 1;
    if (node.kind == FilterNode::Kind::negation) depth += depth_[node.left];
    if (node.kind == FilterNode::Kind::any_of || node.kind == FilterNode::Kind::all_of)
      depth += std::max(depth_[node.left], depth_[node.right]);
    if (depth > max_depth)
      throw FilterError(token_.column,
                        fmt::format("the filter nests deeper than {} levels", max_depth));
    nodes_.push_back(std::move(node));
    depth_.resize(nodes_.size());
    depth_.back() = depth;
    return nodes_.size() - 1;
  }

  size_t either() {
    size_t left = both();
    while (token_.kind == Token::Kind::either) {
      advance();
      left = add({.kind = FilterNode::Kind::any_of, .left = left, .right = both()});
    }
    return left;
  }

  size_t both() {
    size_t left = unary();
    while (token_.kind == Token::Kind::both) {
      advance();
      left = add({.kind = FilterNode::Kind::all_of, .left = left, .right = unary()});
    }
    return left;
  }

  size_t unary() {
    // Parentheses and negations recurse before any node is made: count them here.
    if (++nesting_ > max_depth)
      throw FilterError(token_.column,
                        fmt::format("the filter nests deeper than {} levels", max_depth));
    const size_t made = unary_inner();
    --nesting_;
    return made;
  }

  size_t unary_inner() {
    if (token_.kind == Token::Kind::negate) {
      advance();
      return add({.kind = FilterNode::Kind::negation, .left = unary()});
    }
    if (token_.kind == Token::Kind::open) {
      const size_t column = token_.column;
      advance();
      const size_t inner = either();
      if (token_.kind != Token::Kind::close)
        throw FilterError(token_.column, fmt::format("the '(' at column {} is not closed", column));
      advance();
      return inner;
    }
    return test();
  }

  size_t test() {
    if (token_.kind != Token::Kind::name)
      throw FilterError(token_.column,
                        token_.kind == Token::Kind::end
                            ? std::string("a name is missing at the end")
                            : fmt::format("expected a name, not \"{}\"", token_.text));
    FilterNode node{.kind = FilterNode::Kind::presence, .name = resolve(token_)};
    advance();
    if (token_.kind != Token::Kind::op) return add(std::move(node));
    node.kind = FilterNode::Kind::comparison;
    node.op = token_.op;
    const Token op = token_;
    advance();
    switch (node.op) {
      case Op::in:
        node.set = set(op, node.name);
        break;
      case Op::contains:
        node.literal = {.text = written_bytes(text_of(literal(op)))};
        break;
      case Op::matches:
        node.pattern = pattern(text_of(literal(op)));
        break;
      default:
        node.literal = value(op, node.name);
    }
    advance();
    return add(std::move(node));
  }

  // The literal compared with `name`: an address as text writes it, a fixed field's value.
  Literal value(const Token& op, const Name& name) {
    Literal given = literal(op);
    check_fixed_value(name, given);
    if (given.is_number && names_an_address(name))
      if (const auto reg = parse_register_number(token_.text, base_))
        given.number = reg->address;  // the table a 4xxxx number names is not checked
    return given;
  }

  static bool names_an_address(const Name& name) {
    if (name.kind == NameKind::register_attribute) return name.attribute == RegisterAttribute::addr;
    return name.kind == NameKind::field &&
           std::any_of(name.ids.begin(), name.ids.end(),
                       [](FieldId id) { return field_info(id).type == FieldType::address; });
  }

  // `in {3 5 7}`, `in {1..10, 20}`: each member a value or a range; the closing brace current.
  std::vector<Literal> set(const Token& op, const Name& name) {
    if (token_.kind != Token::Kind::open_set)
      throw FilterError(token_.column, "expected '{' after in");
    std::vector<Literal> members;
    advance();
    while (token_.kind != Token::Kind::close_set) {
      if (token_.kind == Token::Kind::comma) {
        advance();
        continue;
      }
      if (token_.kind == Token::Kind::end)
        throw FilterError(token_.column, "the set has no closing '}'");
      Literal member = value(op, name);
      advance();
      if (token_.kind == Token::Kind::range) {
        advance();
        const Literal last = value(op, name);
        if (!member.is_number || !last.is_number)
          throw FilterError(token_.column, "a range in a set is of numbers: 1..10");
        member.upto = last.number;
        advance();
      }
      members.push_back(std::move(member));
    }
    if (members.empty()) throw FilterError(token_.column, "the set is empty");
    return members;
  }

  // What `contains` and `matches` look for: text, whatever the literal looked like (01 is hex).
  std::string text_of(const Literal& literal) const {
    return literal.is_number ? token_.text : literal.text;
  }

  // Bytes print as hex pairs without separators: "01:03" and "01 03" look for "0103".
  static std::string written_bytes(std::string text) {
    const bool bytes =
        text.size() > 2 && std::all_of(text.begin(), text.end(), [](char c) {
          return std::isxdigit(static_cast<unsigned char>(c)) || c == ':' || c == ' ' || c == '-';
        });
    if (bytes) std::erase_if(text, [](char c) { return c == ':' || c == ' ' || c == '-'; });
    return text;
  }

  // Case does not matter, as in Wireshark's `matches`. libstdc++ compiles a regular expression
  // by recursion, a level or more for each character and group: a pattern is held to what a
  // filter needs, so that no filter text can run the stack out (thousands of '(' did).
  static constexpr size_t max_pattern = 256;
  std::shared_ptr<const std::regex> pattern(const std::string& text) const {
    if (text.size() > max_pattern)
      throw FilterError(token_.column, fmt::format("a regular expression of {} characters: at "
                                                   "most {} are read",
                                                   text.size(), max_pattern));
    try {
      return std::make_shared<const std::regex>(
          text, std::regex::ECMAScript | std::regex::icase | std::regex::optimize);
    } catch (const std::regex_error& e) {
      throw FilterError(token_.column, fmt::format("\"{}\" is no regular expression", text));
    }
  }

  // A field of a fixed set of values compares with one of them, or with what the text output
  // prints for it (role == req): anything else would match nothing, so it is refused.
  void check_fixed_value(const Name& name, Literal& literal) const {
    if (name.kind != NameKind::field || literal.is_number) return;
    for (const FixedValues& field : fixed_values) {
      if (std::find(name.ids.begin(), name.ids.end(), field.id) == name.ids.end()) continue;
      for (const auto& [alias, value] : field.aliases)
        if (equal_ignoring_case(literal.text, alias)) literal.text = value;
      for (std::string_view value : field.values)
        if (equal_ignoring_case(literal.text, value)) return;
      throw FilterError(token_.column,
                        fmt::format("{} is {}, not \"{}\"", field_info(field.id).name,
                                    one_of(field.values), literal.text));
    }
  }

  Literal literal(const Token& op) {
    switch (token_.kind) {
      case Token::Kind::number:
        return {.is_number = true, .number = token_.number};
      case Token::Kind::string:
        return {.text = token_.text};
      case Token::Kind::name:  // a bare word: role == request; or a manual's hex, FFFFH
        if (auto hex = parse_written_number(token_.text))
          return {.is_number = true, .number = static_cast<double>(*hex)};
        return {.text = token_.text};
      default:
        throw FilterError(token_.column, fmt::format("expected a value after {}", op.text));
    }
  }

  Name resolve(const Token& t) {
    Name name;
    const std::string_view word = t.text;
    if (word == "finding" || word == "findings") {
      name.ids = {FieldId::findings};
      return name;
    }
    for (const FieldInfo& field : field_registry())
      if (field.name == word) name.ids.push_back(field.id);
    if (!name.ids.empty()) return name;
    const auto findings = finding_registry();
    for (size_t slot = 0; slot < findings.size(); ++slot)
      if (findings[slot].name == word) {
        name.kind = NameKind::finding;
        name.finding = slot;
        return name;
      }
    if (word.starts_with(register_prefix)) {
      static constexpr std::pair<std::string_view, RegisterAttribute> attributes[] = {
          {"name", RegisterAttribute::name},   {"addr", RegisterAttribute::addr},
          {"value", RegisterAttribute::value}, {"raw", RegisterAttribute::raw},
          {"unit", RegisterAttribute::unit},   {"text", RegisterAttribute::text}};
      for (const auto& [attribute_name, attribute] : attributes)
        if (word.substr(register_prefix.size()) == attribute_name) {
          name.kind = NameKind::register_attribute;
          name.attribute = attribute;
          return name;
        }
    }
    if (is_register_name_ && is_register_name_(word)) {
      name.kind = NameKind::register_named;
      name.register_name = std::string(word);
      return name;
    }
    throw FilterError(t.column, fmt::format("unknown name \"{}\"{}", word, suggestion(word)));
  }

  Lexer lexer_;
  const std::function<bool(std::string_view)>& is_register_name_;
  RegisterBase base_;
  std::vector<FilterNode>& nodes_;
  std::vector<size_t> depth_;  // of each node's subtree
  size_t nesting_ = 0;
  Token token_;
};

// ---- Values of a name on a record --------------------------------------------------------

// Hex as JSON writes bytes, into a scratch buffer.
std::string_view hex(std::span<const uint8_t> bytes, std::string& scratch) {
  static constexpr char digits[] = "0123456789abcdef";
  scratch.clear();
  for (uint8_t b : bytes) {
    scratch += digits[b >> 4];
    scratch += digits[b & 15];
  }
  return scratch;
}

// Calls visit(value) for each value; stops and returns true as soon as visit does.
template <typename Visit>
bool pdu_values(const Name& name, const DecodedPdu& pdu, std::string& scratch, Visit&& visit) {
  for (const Field& f : pdu.fields) {
    if (std::find(name.ids.begin(), name.ids.end(), f.id) == name.ids.end()) continue;
    switch (f.type()) {
      case FieldType::registers:
        for (size_t i = 0; i < f.count; ++i)
          if (visit(number(f.word(i)))) return true;
        break;
      case FieldType::bits:
        for (size_t i = 0; i < f.count; ++i)
          if (visit(number(f.bit(i)))) return true;
        break;
      case FieldType::name:
        if (visit(text(f.text))) return true;
        break;
      case FieldType::string:
        if (visit(text({reinterpret_cast<const char*>(f.bytes.data()), f.bytes.size()})))
          return true;
        break;
      case FieldType::bytes:
        if (visit(text(hex(f.bytes, scratch)))) return true;
        break;
      case FieldType::list:
        if (visit(number(f.count))) return true;
        break;
      default:
        if (visit(number(static_cast<double>(f.number)))) return true;
    }
  }
  return false;
}

template <typename Visit>
bool register_values(const Name& name, std::span<const RegisterValue> registers, Visit&& visit) {
  for (const RegisterValue& reg : registers) {
    if (name.kind == NameKind::register_named) {
      if (reg.name != name.register_name) continue;
      if (visit(Value{true, reg.value, !reg.text.empty(), reg.text})) return true;
      continue;
    }
    Value v;
    switch (name.attribute) {
      case RegisterAttribute::name:
        v = text(reg.name);
        break;
      case RegisterAttribute::addr:
        v = number(reg.address);
        break;
      case RegisterAttribute::value:
        v = Value{true, reg.value, !reg.text.empty(), reg.text};
        break;
      case RegisterAttribute::raw:
        v = number(reg.raw);
        break;
      case RegisterAttribute::unit:
        v = text(reg.unit);
        break;
      case RegisterAttribute::text:
        v = text(reg.text);
        break;
    }
    if (visit(v)) return true;
  }
  return false;
}

// Evaluates the walk over a record's fields (decoder/models/record_fields.hpp): hands the values of
// one name to `visit` until one satisfies it, which `found` then says.
template <typename Visit>
class NameValues {
 public:
  NameValues(const Name& name, const std::vector<std::string>& channels, std::string& scratch,
             Visit& visit)
      : name_(name), channels_(channels), scratch_(scratch), visit_(visit) {}
  bool found = false;

  void name(FieldId id, std::string_view t) {
    offer(id, [&] { return text(t); });
  }
  template <NamedEnum Enum>
  void choice(FieldId id, Enum value) {
    name(id, to_string(value));
  }
  void function_code(FieldId fc, FieldId function, uint8_t byte) {
    number(fc, byte & 0x7F);
    name(function, function_label(byte));
  }
  void number(FieldId id, uint64_t n) {
    offer(id, [&] { return modtap::number(static_cast<double>(n)); });
  }
  void time(FieldId id, int64_t ns) {
    offer(id, [&] { return modtap::number(static_cast<double>(ns)); });
  }
  void micros(FieldId id, int64_t ns) {
    offer(id, [&] { return modtap::number(static_cast<double>(ns) / 1000); });
  }
  void channel(FieldId id, uint16_t number) {
    offer(id, [&] {
      return text(number < channels_.size() ? std::string_view(channels_[number]) : "");
    });
  }
  void bytes(FieldId id, std::span<const uint8_t> bytes) {
    offer(id, [&] { return text(hex(bytes, scratch_)); });
  }
  void boolean(FieldId id, bool value) {
    if (value) flag(id);  // as a flag: present where true
  }
  void flag(FieldId id) {
    offer(id, [] { return modtap::number(1); });
  }
  void absent(FieldId) {}
  void findings(FieldId id, FindingSlots slots) {
    if (found) return;
    if (name_.kind == NameKind::finding) {
      found = slots.has(name_.finding) && visit_(modtap::number(1));
      return;
    }
    if (!wants(id)) return;
    const auto names = finding_registry();
    slots.each([&](size_t slot) { found = found || visit_(text(names[slot].name)); });
  }
  void registers(FieldId id, std::span<const RegisterValue> registers) {
    if (found) return;
    if (name_.kind == NameKind::register_attribute || name_.kind == NameKind::register_named) {
      found = register_values(name_, registers, visit_);
      return;
    }
    if (!registers.empty()) offer(id, [&] { return modtap::number(registers.size()); });
  }
  void notes(FieldId id, std::span<const RuleFinding> notes) {
    if (!notes.empty()) offer(id, [&] { return modtap::number(notes.size()); });
  }
  void pdu(const DecodedPdu& pdu) {
    if (!found && name_.kind == NameKind::field) found = pdu_values(name_, pdu, scratch_, visit_);
  }

 private:
  bool wants(FieldId id) const {
    return name_.kind == NameKind::field &&
           std::find(name_.ids.begin(), name_.ids.end(), id) != name_.ids.end();
  }
  template <typename Make>
  void offer(FieldId id, Make&& make) {
    if (!found && wants(id)) found = visit_(make());
  }

  const Name& name_;
  const std::vector<std::string>& channels_;
  std::string& scratch_;
  Visit& visit_;
};

// A record as the filter sees it: the walk over its fields.
template <typename Walk>
struct WalkedRecord {
  Walk walk;
  const std::vector<std::string>& channels;
  template <typename Visit>
  bool any(const Name& name, std::string& scratch, Visit&& visit) const {
    NameValues<std::remove_reference_t<Visit>> values(name, channels, scratch, visit);
    walk(values);
    return values.found;
  }
};
template <typename Walk>
WalkedRecord(Walk, const std::vector<std::string>&) -> WalkedRecord<Walk>;

template <typename Record>
bool evaluate(const std::vector<FilterNode>& nodes, size_t at, const Record& record,
              std::string& scratch) {
  const FilterNode& node = nodes[at];
  switch (node.kind) {
    case FilterNode::Kind::any_of:
      return evaluate(nodes, node.left, record, scratch) ||
             evaluate(nodes, node.right, record, scratch);
    case FilterNode::Kind::all_of:
      return evaluate(nodes, node.left, record, scratch) &&
             evaluate(nodes, node.right, record, scratch);
    case FilterNode::Kind::negation:
      return !evaluate(nodes, node.left, record, scratch);
    case FilterNode::Kind::presence:
      return record.any(node.name, scratch, [](const Value&) { return true; });
    case FilterNode::Kind::comparison: {
      const bool any =
          record.any(node.name, scratch, [&](const Value& v) { return compare(v, node); });
      return node.op == Op::ne ? !any : any;
    }
  }
  return false;
}

}  // namespace

DisplayFilter::DisplayFilter(std::string_view text,
                             std::function<bool(std::string_view)> is_register_name,
                             RegisterBase base) {
  Parser(text, is_register_name, base, nodes_).parse();
}
DisplayFilter::~DisplayFilter() = default;
DisplayFilter::DisplayFilter(DisplayFilter&&) noexcept = default;

bool DisplayFilter::matches(const Frame& frame, const DecodedPdu& pdu) const {
  const WalkedRecord record{[&](auto& fields) { walk_fields(frame, pdu, fields); }, channels_};
  return evaluate(nodes_, 0, record, scratch_);
}
bool DisplayFilter::matches(const Noise& noise) const {
  const WalkedRecord record{[&](auto& fields) { walk_fields(noise, fields); }, channels_};
  return evaluate(nodes_, 0, record, scratch_);
}
bool DisplayFilter::matches(const Timeout& timeout) const {
  const WalkedRecord record{[&](auto& fields) { walk_fields(timeout, fields); }, channels_};
  return evaluate(nodes_, 0, record, scratch_);
}

FilterStage::FilterStage(DisplayFilter filter, RecordSink& next)
    : filter_(std::move(filter)), next_(next) {}

void FilterStage::on_frame(const Frame& frame) {
  decode_frame(frame, decoded_);
  if (!filter_.matches(frame, decoded_)) return;
  Frame decoded = frame;
  decoded.decoded = &decoded_;
  next_.on_frame(decoded);
}

void FilterStage::on_noise(const Noise& noise) {
  if (filter_.matches(noise)) next_.on_noise(noise);
}

void FilterStage::on_timeout(const Timeout& timeout) {
  if (filter_.matches(timeout)) next_.on_timeout(timeout);
}

}  // namespace modtap
