// A minimal pcapng writer: one section, interfaces with a name and nanosecond time stamps,
// enhanced packet blocks with direction flags and a comment. libpcap reads pcapng but writes
// only pcap, which has no interfaces, no direction and no comments; see docs/pcapng.md.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "captures/output_file.hpp"

namespace modtap::captures {

enum class PacketDirection : uint8_t { unknown = 0, inbound = 1, outbound = 2 };

class PcapngWriter {
 public:
  // Throws WriteError when the file cannot be created or written. "-" is standard output.
  // `live`: a reader follows the file as it grows (a FIFO, a pipe), so the header and every
  // packet are flushed at once.
  explicit PcapngWriter(const std::string& path, bool live = false);
  // Writes out what it holds, ignoring failures: call close() to learn of them.
  ~PcapngWriter();
  PcapngWriter(const PcapngWriter&) = delete;
  PcapngWriter& operator=(const PcapngWriter&) = delete;

  // Returns the interface id for the packets that follow.
  uint32_t add_interface(int link_type, std::string_view name, std::string_view comment = {});
  // With a `hold` key other than 0 the packet is held: it and every packet after it stay in
  // memory, its comment open to extend_comment(), until release(hold). Bounded: past 4,096
  // held packets, or 4 MiB from the first of them on, the oldest goes out as it is.
  void write_packet(uint32_t interface, int64_t t_ns, std::span<const uint8_t> data,
                    PacketDirection direction, std::string_view comment, uint64_t hold = 0);
  // Appends to a held packet's comment's first line, where readers take its verdicts from (no
  // more than a comment's 65,535 bytes).
  void extend_comment(uint64_t hold, std::string_view more);
  void release(uint64_t hold);  // a key not held is no error: it may have gone out already
  void release_all();
  void flush();  // writes out all but the held packets and what follows them
  // Everything this file will hold so far: written, or still in memory.
  uint64_t bytes_written() const { return file_.bytes_written() + (end_ - begin_); }
  // Writes out everything, held or not, and closes the file, reporting any failure.
  void close();

 private:
  class Block;  // one block being built
  struct Hold {
    uint64_t key;
    uint64_t at;  // where its block starts, counted from the file's first byte
  };

  void write_section_header();
  uint8_t* room(size_t n);  // n more pending bytes, to be written by the caller
  void grow(size_t n);
  void insert_room(size_t at, size_t n);
  void write_out(size_t n);  // at block boundaries only: it may move what is left
  void write_due();
  size_t writable() const;

  OutputFile file_;
  // The blocks not yet written, built in place: a packet is copied once, into here, and the
  // file is written in large pieces of whole blocks. Not a vector: growing it need not zero it.
  std::unique_ptr<uint8_t[]> pending_;
  size_t begin_ = 0;  // pending_[begin_, end_) is not written yet
  size_t end_ = 0;
  size_t capacity_ = 0;
  std::vector<Hold> holds_;  // in file order
  bool live_ = false;
  bool closed_ = false;
  uint32_t interfaces_ = 0;
};

}  // namespace modtap::captures
