#include "captures/hexlog_reader.hpp"

#include <algorithm>
#include <cctype>
#include <ctime>
#include <limits>
#include <utility>

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

bool all_hex(const std::string& s, size_t at, size_t n) {
  for (size_t i = at; i < at + n; ++i)
    if (!std::isxdigit(static_cast<unsigned char>(s[i]))) return false;
  return true;
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
    last_blocks_.emplace_back();
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
  block_.stamp_ns = static_cast<int64_t>(seconds) * 1'000'000'000 + number(s, 20, 6) * 1000LL;
  block_.channel = channel_for(s.size() > stamp_size ? s.substr(stamp_size + 1) : std::string());
}

// Appends a line's bytes to the block: the hex after --byte-count's eight digits and a tab,
// before --ascii's tab and text column.
void HexlogReader::add_line(const std::string& line) {
  size_t at = 0;
  if (line.size() > 8 && line[8] == '\t' && all_hex(line, 0, 8)) at = 9;
  const size_t end = std::min(line.find('\t', at), line.size());
  const size_t before = block_.bytes.size();
  for (size_t i = at; i < end;) {
    if (line[i] == ' ') {
      ++i;
      continue;
    }
    const int hi = hex_digit(line[i]);
    const int lo = i + 1 < end ? hex_digit(line[i + 1]) : -1;
    if (hi < 0 || lo < 0 || (i + 2 < end && line[i + 2] != ' '))
      throw CaptureError(fmt::format("{}: line {}, column {}: expected a hex byte, found \"{}\"",
                                     lines_.path(), lines_.line_number(), i + 1,
                                     printable(line.substr(i, std::min<size_t>(8, end - i)))));
    block_.bytes.push_back(static_cast<uint8_t>(hi << 4 | lo));
    i += 2;
  }
  if (block_.bytes.size() > before) block_.line_ends.push_back(block_.bytes.size());
}

// The next block's stamp: the line that ended the block before, or the next stamp line. False
// at the end of the file.
bool HexlogReader::begin_block() {
  block_.bytes.clear();
  block_.line_ends.clear();
  block_.next_line = 0;
  if (std::exchange(block_continues_, false)) return true;
  if (next_header_) {
    start_block(*next_header_);
    next_header_.reset();
    return true;
  }
  while (lines_.next(line_)) {
    if (is_header(line_)) {
      start_block(line_);
      return true;
    }
    add_line(line_);
    if (!block_.bytes.empty())
      throw CaptureError(fmt::format("{}: line {}: bytes before the first time stamp line",
                                     lines_.path(), lines_.line_number()));
  }
  return false;
}

// Reads a block's lines, up to the next stamp line, the end of the file or max_block_bytes,
// and places them in time: see the header.
bool HexlogReader::read_block() {
  bool continued = false;
  do {
    continued = block_continues_;
    if (!begin_block()) return false;
    while (block_.bytes.size() < max_block_bytes && lines_.next(line_)) {
      if (is_header(line_)) {
        next_header_ = line_;
        break;
      }
      add_line(line_);
    }
    block_continues_ = block_.bytes.size() >= max_block_bytes;
  } while (block_.bytes.empty());
  const int64_t duration_ns = static_cast<int64_t>(block_.bytes.size()) * char_time_ns_;
  LastBlock& last = last_blocks_[block_.channel];
  block_.start_ns = block_.stamp_ns - duration_ns;
  block_.follows_unknown_silence =
      continued || (block_.stamp_ns >= last.stamp_ns && block_.start_ns < last.end_ns);
  if (block_.follows_unknown_silence) block_.start_ns = last.end_ns;
  last = {block_.stamp_ns, block_.start_ns + duration_ns};
  return true;
}

bool HexlogReader::next(Chunk& chunk) {
  if (block_.next_line == block_.line_ends.size() && !read_block()) return false;
  const size_t line = block_.next_line++;
  const size_t from = line == 0 ? 0 : block_.line_ends[line - 1];
  const size_t to = block_.line_ends[line];
  chunk = {block_.channel, block_.start_ns + static_cast<int64_t>(to) * char_time_ns_,
           std::span<const uint8_t>(block_.bytes).subspan(from, to - from),
           line > 0 || block_.follows_unknown_silence};
  return true;
}

}  // namespace modtap::captures
