#include "captures/hexlog_reader.hpp"

#include <cctype>
#include <ctime>

#include <fmt/format.h>

namespace modtap::captures {
namespace {

constexpr size_t stamp_size = 27;  // "2026-11-22 10:57:33.761949:"

bool digits(const std::string& s, size_t at, size_t n) {
  for (size_t i = at; i < at + n; ++i)
    if (!std::isdigit(static_cast<unsigned char>(s[i]))) return false;
  return true;
}

int number(const std::string& s, size_t at, size_t n) {
  return std::stoi(s.substr(at, n));
}

// Binary junk in a message would upset the terminal: show it as \xNN.
std::string printable(const std::string& s) {
  std::string out;
  for (unsigned char c : s)
    out += std::isprint(c) ? std::string(1, static_cast<char>(c)) : fmt::format("\\x{:02x}", c);
  return out;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace

HexlogReader::HexlogReader(const std::string& path, int64_t char_time_ns)
    : lines_(path), char_time_ns_(char_time_ns) {}

bool HexlogReader::is_header(const std::string& s) {
  return s.size() >= stamp_size && digits(s, 0, 4) && s[4] == '-' && digits(s, 5, 2) &&
         s[7] == '-' && digits(s, 8, 2) && s[10] == ' ' && digits(s, 11, 2) && s[13] == ':' &&
         digits(s, 14, 2) && s[16] == ':' && digits(s, 17, 2) && s[19] == '.' && digits(s, 20, 6) &&
         s[26] == ':' && (s.size() == stamp_size || s[stamp_size] == ' ');
}

uint16_t HexlogReader::channel_for(const std::string& name) {
  auto [it, added] = channel_ids_.try_emplace(name, static_cast<uint16_t>(channels_.size()));
  if (added) {
    // Ports named like the two sides of a split tap say which direction they carry.
    auto role = name == "master"  ? ChannelRole::master
                : name == "slave" ? ChannelRole::slave
                                  : ChannelRole::bus;
    channels_.push_back({name.empty() ? lines_.path() : name, role});
  }
  return it->second;
}

// jpnevulator prints local time without a zone; mktime reads it back the same way. A stamp
// that is no calendar time (month 13, year 9999) is an error, not a time mktime wraps.
void HexlogReader::start_block(const std::string& s) {
  const bool calendar = number(s, 0, 4) >= 1970 && number(s, 0, 4) <= 2200 &&
                        number(s, 5, 2) >= 1 && number(s, 5, 2) <= 12 && number(s, 8, 2) >= 1 &&
                        number(s, 8, 2) <= 31 && number(s, 11, 2) <= 23 && number(s, 14, 2) <= 59 &&
                        number(s, 17, 2) <= 60;
  if (!calendar)
    throw CaptureError(fmt::format("{}: line {}: \"{}\" is not a time stamp", lines_.path(),
                                   lines_.line_number(), s.substr(0, stamp_size - 1)));
  std::tm tm{};
  tm.tm_year = number(s, 0, 4) - 1900;
  tm.tm_mon = number(s, 5, 2) - 1;
  tm.tm_mday = number(s, 8, 2);
  tm.tm_hour = number(s, 11, 2);
  tm.tm_min = number(s, 14, 2);
  tm.tm_sec = number(s, 17, 2);
  tm.tm_isdst = -1;
  const std::time_t seconds = std::mktime(&tm);
  block_start_ns_ = static_cast<int64_t>(seconds) * 1'000'000'000 + number(s, 20, 6) * 1000LL;
  channel_ = channel_for(s.size() > stamp_size ? s.substr(stamp_size + 1) : std::string());
  block_bytes_ = 0;
  in_block_ = true;
}

bool HexlogReader::next(Chunk& chunk) {
  while (lines_.next(line_)) {
    if (is_header(line_)) {
      start_block(line_);
      continue;
    }
    // With --ascii the hex is followed by a tab and a printable column.
    const std::string hex = line_.substr(0, line_.find('\t'));
    bytes_.clear();
    for (size_t i = 0; i < hex.size();) {
      if (hex[i] == ' ') {
        ++i;
        continue;
      }
      const int hi = hex_digit(hex[i]);
      const int lo = i + 1 < hex.size() ? hex_digit(hex[i + 1]) : -1;
      if (hi < 0 || lo < 0 || (i + 2 < hex.size() && hex[i + 2] != ' '))
        throw CaptureError(fmt::format("{}: line {}, column {}: expected a hex byte, found \"{}\"",
                                       lines_.path(), lines_.line_number(), i + 1,
                                       printable(hex.substr(i, 8))));
      bytes_.push_back(static_cast<uint8_t>(hi << 4 | lo));
      i += 2;
    }
    if (bytes_.empty()) continue;
    if (!in_block_)
      throw CaptureError(fmt::format("{}: line {}: bytes before the first time stamp line",
                                     lines_.path(), lines_.line_number()));
    block_bytes_ += bytes_.size();
    chunk = {channel_, block_start_ns_ + static_cast<int64_t>(block_bytes_) * char_time_ns_,
             bytes_};
    return true;
  }
  return false;
}

}  // namespace modtap::captures
