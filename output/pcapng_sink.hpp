// Writes modtap's records as pcapng for Wireshark: one packet per frame and per noise record,
// one interface per channel, the direction in epb_flags and the verdicts in a comment.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "captures/file_ring.hpp"
#include "captures/pcapng_writer.hpp"
#include "decoder/protocol/record_sink.hpp"

namespace modtap {
struct DeviceModel;
}

namespace modtap::output {

enum class PcapngLink {
  user,          // DLT_USER: the wire bytes, verdicts in the comment (for plugins/wireshark)
  exported_pdu,  // link type 252: stock Wireshark's mbrtu dissector, classified by port
  bare,          // DLT_USER with frames only and no comments, as other sniffers write
};

struct PcapngOptions {
  PcapngLink link = PcapngLink::user;
  int dlt = 147;
  // Exported PDU: the slave side of every frame sits on this TCP port, so that
  // `-o mbrtu.tcp.port:502` tells Wireshark which frames are requests.
  uint32_t slave_port = 502;
  uint32_t master_port = 50200;
  // How well the source knew each byte's time: said in the file, so a reread times alike.
  ClockQuality clock = ClockQuality::per_chunk;
  // A character's time on the line, said in each interface's comment: a record that lasted its
  // bytes times this needs no duration of its own. 0 where the line's speed is not known.
  int64_t char_ns = 0;
  // Someone reads the file as it grows (a port's capture into Wireshark's FIFO or a pipe):
  // every packet is flushed as it is written.
  bool live = false;
};

// Parses "user", "exported-pdu" or "bare"; throws std::invalid_argument.

class PcapngSink final : public RecordSink {
 public:
  PcapngSink(captures::PcapngWriter& writer, const std::vector<ChannelInfo>& channels,
             const PcapngOptions& options);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  // A request that timed out gets "timeout=REASON waited_us=N" in its comment.
  void on_timeout(const Timeout& timeout) override;
  // Writes what is held (requests still waiting, and what came after them).
  void finish();
  uint64_t packets() const { return packets_; }  // records written, one packet each

 private:
  uint32_t interface_for(uint16_t channel);
  int64_t resolution_ns() const { return options_.clock == ClockQuality::per_byte ? 1 : 1000; }
  std::span<const uint8_t> exported_pdu(std::string_view protocol, bool from_master,
                                        std::span<const uint8_t> payload);

  captures::PcapngWriter& writer_;
  const std::vector<ChannelInfo>& channels_;
  PcapngOptions options_;
  std::vector<int64_t> interface_of_channel_;  // -1 until its interface block is written
  std::vector<uint8_t> payload_;
  fmt::memory_buffer comment_;  // the packet's comment, its storage kept from frame to frame
  uint64_t last_index_ = 0;     // the record the last packet held
  // Per first byte (the address on the wire), the model its last frame was read with.
  std::array<const DeviceModel*, 256> model_of_address_{};
  uint64_t packets_ = 0;
};

// -w: the pcapng file, or with -b a ring of them. Each file is whole (its own section and
// interfaces), and a record is never split between two.
class PcapngFiles final : public RecordSink {
 public:
  // Without rotation the file is created at once (an empty capture leaves an empty pcapng);
  // with it, each file when its first record comes.
  PcapngFiles(const std::string& path, const captures::RingLimits& limits,
              const std::vector<ChannelInfo>& channels, const PcapngOptions& options);

  void on_frame(const Frame& frame) override;
  void on_noise(const Noise& noise) override;
  void on_timeout(const Timeout& timeout) override;

  uint64_t bytes_written() const;  // by all its files together
  uint64_t files_begun() const { return ring_.files_begun(); }
  uint64_t packets() const;  // records written, one packet each, by all its files
  // Completes the last file (or the one file of a run that saw no record), reporting failures.
  void close();

 private:
  PcapngSink& sink_at(int64_t t_ns);
  void begin_file(const std::string& path);

  captures::FileRing ring_;
  const std::vector<ChannelInfo>& channels_;
  PcapngOptions options_;
  uint64_t closed_bytes_ = 0;  // what the files before the current one hold
  uint64_t closed_packets_ = 0;
  std::unique_ptr<captures::PcapngWriter> writer_;
  std::unique_ptr<PcapngSink> sink_;
};

// What a reader of modtap's pcapng knows of a packet before its comment (docs/pcapng.md): the
// comment carries a key only where the record differs, so that it holds what Wireshark cannot
// know and little else.
struct CommentDefaults {
  uint64_t index = 0;         // the record the packet before was (0: the file's first packet)
  Role role = Role::unknown;  // the role the packet's direction says
  int64_t char_ns = 0;        // a character's time on the line: a record lasts its bytes times this
  const DeviceModel* model = nullptr;  // the model the last frame of this address was read with
  // What the source's clock can tell: latencies and waits are written to it, whole microseconds
  // where it stamps reads or packets, nanoseconds where it times each byte (a logic analyzer).
  int64_t resolution_ns = 1;
};

// What modtap says of each interface it writes: the time convention (pcapng_format.hpp),
// the channel's role (a split tap), the source's clock and a character's time (0: unknown).
std::string interface_comment(ChannelRole role, ClockQuality clock, int64_t char_ns);

// The comment modtap writes on a frame or noise record: "modtap key=value ...", then a line per
// register and model finding; parsed by the Wireshark plugin and by modtap's pcapng reader.
std::string frame_comment(const Frame& frame, const CommentDefaults& defaults = {});
void append_frame_comment(fmt::memory_buffer& out, const Frame& frame,
                          const CommentDefaults& defaults);
std::string noise_comment(const Noise& noise, const CommentDefaults& defaults = {});
void append_noise_comment(fmt::memory_buffer& out, const Noise& noise,
                          const CommentDefaults& defaults);
// What a time-out adds to its request's comment: " waited_us=... timeout=REASON"; nothing
// where the capture ended before the request's time ran out.
void append_timeout_comment(fmt::memory_buffer& out, const Timeout& timeout,
                            const CommentDefaults& defaults = {});

}  // namespace modtap::output

template <>
struct modtap::EnumNames<modtap::output::PcapngLink> {
  static constexpr std::array<std::string_view, 3> names{"user", "exported-pdu", "bare"};
};
