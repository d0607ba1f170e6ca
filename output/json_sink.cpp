#include "output/json_sink.hpp"

#include <algorithm>
#include <array>
#include <string>

#include "decoder/models/record_fields.hpp"
#include "decoder/protocol/pdu_fields.hpp"
#include "output/render.hpp"

namespace modtap::output {

JsonSink::JsonSink(Output& out, const std::vector<ChannelInfo>& channels)
    : out_(out), channels_(channels) {}

// Escaped once per channel rather than for every record.
void JsonSink::channel(uint16_t id) {
  if (id >= channel_keys_.size()) channel_keys_.resize(id + 1u);
  ChannelKey& key = channel_keys_[id];
  const std::string& name = id < channels_.size() ? channels_[id].name : key.name;
  if (key.json.size() == 0 || key.name != name) {
    key.name = name;
    key.json.clear();
    put(key.json, ",\"channel\":");
    append_json_string(key.json, name);
  }
  put(out_.buffer(), {key.json.data(), key.json.size()});
}

namespace {

// `,"name":` of each field, made at compile time from the registry; a record's first field,
// always its type, opens the object instead. Keys are most of a JSON line's pieces.
template <FieldId id>
constexpr auto json_key = [] {
  constexpr std::string_view name = field_info(id).name;
  std::array<char, name.size() + 4> key{};
  key[0] = id == FieldId::type ? '{' : ',';
  key[1] = '"';
  std::copy(name.begin(), name.end(), key.begin() + 2);
  key[name.size() + 2] = '"';
  key[name.size() + 3] = ':';
  return key;
}();

// A field's key and a value that never changes, made at compile time.
template <FieldId id, size_t size>
constexpr auto keyed(const char (&value)[size]) {
  std::array<char, json_key<id>.size() + size - 1> piece{};
  std::copy(json_key<id>.begin(), json_key<id>.end(), piece.begin());
  std::copy(value, value + size - 1, piece.begin() + json_key<id>.size());
  return piece;
}
template <FieldId id>
constexpr auto json_null = keyed<id>("null");
template <FieldId id>
constexpr auto json_true = keyed<id>("true");

template <size_t size>
void put_piece(fmt::memory_buffer& out, const std::array<char, size>& piece) {
  put(out, {piece.data(), size});
}
template <FieldId id>
void put_key(fmt::memory_buffer& out) {
  put_piece(out, json_key<id>);
}

// `,"mode":"rtu"` for each value of a field's enumeration, made at compile time.
template <FieldId id, NamedEnum Enum>
struct JsonChoices {
  static constexpr const auto& names = EnumNames<Enum>::names;
  static constexpr size_t longest = std::ranges::max(names, {}, &std::string_view::size).size();
  struct Piece {
    std::array<char, json_key<id>.size() + longest + 2> text{};
    size_t size = 0;
  };
  static constexpr auto pieces = [] {
    std::array<Piece, names.size()> made{};
    for (size_t i = 0; i < names.size(); ++i) {
      Piece& piece = made[i];
      for (const char c : json_key<id>) piece.text[piece.size++] = c;
      piece.text[piece.size++] = '"';
      for (const char c : names[i]) piece.text[piece.size++] = c;
      piece.text[piece.size++] = '"';
    }
    return made;
  }();
};

// `,"fc":3,"function":"Read Holding Registers"` for each function code byte, made once.
std::string_view function_code_piece(uint8_t byte) {
  static const auto pieces = texts_per_byte([](fmt::memory_buffer& piece, uint8_t code) {
    put_key<FieldId::fc>(piece);
    put_uint(piece, code & 0x7F);
    put_key<FieldId::function>(piece);
    piece.push_back('"');
    put(piece, function_label(code));
    piece.push_back('"');
  });
  return pieces[byte];
}

}  // namespace

// Renders the walk over a record's fields (decoder/models/record_fields.hpp) as one JSON object.
class JsonSink::Fields {
 public:
  explicit Fields(JsonSink& sink) : sink_(sink), buf_(sink.out_.buffer()) {}

  template <FieldId id>
  void name(FieldTag<id>, std::string_view text) {
    if constexpr (id == FieldId::model) {
      sink_.model_key(text);  // a name from a YAML file, escaped once
    } else {
      put_key<id>(buf_);
      buf_.push_back('"');
      put(buf_, text);
      buf_.push_back('"');
    }
  }
  template <FieldId id, NamedEnum Enum>
  void choice(FieldTag<id>, Enum value) {
    const auto& piece = JsonChoices<id, Enum>::pieces[static_cast<size_t>(value)];
    put(buf_, {piece.text.data(), piece.size});
  }
  template <FieldId fc, FieldId function>
  void function_code(FieldTag<fc>, FieldTag<function>, uint8_t byte) {
    put(buf_, function_code_piece(byte));
  }
  template <FieldId id>
  void number(FieldTag<id>, uint64_t n) {
    put_key<id>(buf_);
    put_uint(buf_, n);
  }
  template <FieldId id>
  void time(FieldTag<id>, int64_t ns) {
    put_key<id>(buf_);
    sink_.time_text_.put(buf_, ns);
  }
  template <FieldId id>
  void micros(FieldTag<id>, int64_t ns) {
    put_key<id>(buf_);
    put_fixed(buf_, Fixed{ns, 3, 3});
  }
  void channel(FieldId, uint16_t number) { sink_.channel(number); }
  template <FieldId id>
  void bytes(FieldTag<id>, std::span<const uint8_t> bytes) {
    put_key<id>(buf_);
    buf_.push_back('"');
    append_hex(buf_, bytes, false);
    buf_.push_back('"');
  }
  template <FieldId id>
  void boolean(FieldTag<id>, bool value) {
    put_key<id>(buf_);
    put(buf_, value ? "true" : "false");
  }
  template <FieldId id>
  void absent(FieldTag<id>) {
    put_piece(buf_, json_null<id>);
  }
  template <FieldId id>
  void flag(FieldTag<id>) {
    put_piece(buf_, json_true<id>);
  }
  template <FieldId id>
  void findings(FieldTag<id>, FindingSlots slots) {
    put_key<id>(buf_);
    buf_.push_back('[');
    const auto names = finding_registry();
    bool first = true;
    slots.each([&](size_t slot) {
      if (!first) buf_.push_back(',');
      first = false;
      buf_.push_back('"');
      put(buf_, names[slot].name);
      buf_.push_back('"');
    });
    buf_.push_back(']');
  }
  template <FieldId id>
  void registers(FieldTag<id>, std::span<const RegisterValue> values) {
    put_key<id>(buf_);
    buf_.push_back('[');
    for (size_t i = 0; i < values.size(); ++i) {
      if (i) buf_.push_back(',');
      append_register_json(buf_, values[i]);
    }
    buf_.push_back(']');
  }
  template <FieldId id>
  void notes(FieldTag<id>, std::span<const RuleFinding> notes) {
    put_key<id>(buf_);
    append_notes(notes);
  }
  void pdu(const DecodedPdu& pdu) {
    for (size_t at = 0; at < pdu.fields.size();) {
      buf_.push_back(',');
      at = append_json_field(buf_, pdu, at);
    }
  }

 private:
  // Each model finding's kind, address and explanation.
  void append_notes(std::span<const RuleFinding> notes) {
    buf_.push_back('[');
    for (size_t i = 0; i < notes.size(); ++i) {
      const RuleFinding& finding = notes[i];
      if (i) buf_.push_back(',');
      put(buf_, "{\"finding\":\"");
      put(buf_, to_string(finding.kind));
      put(buf_, "\",\"addr\":");
      if (finding.address) {
        put_uint(buf_, *finding.address);
      } else {
        put(buf_, "null");
      }
      put(buf_, ",\"text\":");
      append_json_string(buf_, finding.text);
      buf_.push_back('}');
    }
    buf_.push_back(']');
  }

  JsonSink& sink_;
  fmt::memory_buffer& buf_;
};

// `,"model":"NAME"`, escaped once per model rather than for every record.
void JsonSink::model_key(std::string_view name) {
  if (model_key_.size() == 0 || name.data() != model_name_.data() ||
      name.size() != model_name_.size()) {
    model_name_ = name;
    model_key_.clear();
    put_key<FieldId::model>(model_key_);
    append_json_string(model_key_, name);
  }
  put(out_.buffer(), {model_key_.data(), model_key_.size()});
}

void JsonSink::on_frame(const Frame& frame) {
  Fields fields(*this);
  walk_fields(frame, fields_of(frame, decoded_), fields);
  put(out_.buffer(), "}\n");
  out_.end_record();
}

void JsonSink::on_noise(const Noise& noise) {
  Fields fields(*this);
  walk_fields(noise, fields);
  put(out_.buffer(), "}\n");
  out_.end_record();
}

void JsonSink::on_timeout(const Timeout& timeout) {
  Fields fields(*this);
  walk_fields(timeout, fields);
  put(out_.buffer(), "}\n");
  out_.end_record();
}

}  // namespace modtap::output
