// Pieces shared by the text and JSON sinks: hex, JSON strings, field values, finding names.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include <fmt/format.h>

#include "decoder/pdu_fields.hpp"
#include "decoder/records.hpp"
#include "decoder/register_meaning.hpp"

namespace modtap::tools {

void append_hex(fmt::memory_buffer& out, std::span<const uint8_t> bytes, bool spaced);
void append_json_string(fmt::memory_buffer& out, std::string_view text);
void append_json_value(fmt::memory_buffer& out, const decoder::Field& field);
void append_text_value(fmt::memory_buffer& out, const decoder::Field& field, size_t max_items);

// The same as a JSON object: {"addr", "name", "raw", "value", "unit", "text"}.
void append_register_json(fmt::memory_buffer& out, const decoder::RegisterValue& reg);

// "Read Holding Registers", or "Function 0x41" for a code the standard does not name.
std::string function_label(uint8_t fc);

}  // namespace modtap::tools
