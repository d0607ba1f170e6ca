#include "captures/pcapng_writer.hpp"

#include <gtest/gtest.h>
#include <pcap/pcap.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "decoder/models/device_model.hpp"
#include "decoder/models/register_meaning.hpp"
#include "output/pcapng_sink.hpp"
#include "tests/support/collector.hpp"

namespace modtap::captures {
namespace {

using testing::hex;

// Request `request` timed out in silence after `waited_ns`, as record `index`.
Timeout silent_time_out(uint64_t index, uint64_t request, int64_t waited_ns) {
  Timeout timeout;
  timeout.index = index;
  timeout.request = request;
  timeout.waited_ns = waited_ns;
  timeout.reason = TimeoutReason::silence;
  return timeout;
}

std::string temp_path(const char* name) {
  return (std::filesystem::temp_directory_path() / name).string();
}

TEST(PcapngWriter, LibpcapReadsBackPacketsWithNanosecondTimes) {
  const auto path = temp_path("modtap-writer-test.pcapng");
  {
    PcapngWriter writer(path);
    const uint32_t bus = writer.add_interface(147, "bus");
    const auto frame = hex("01 03 00 00 00 0a c5 cd");
    writer.write_packet(bus, 1'700'000'000'123'456'789, frame, PacketDirection::outbound,
                        "modtap index=1");
    writer.write_packet(bus, 1'700'000'001'000'000'001, hex("00"), PacketDirection::unknown, {});
  }
  char error[PCAP_ERRBUF_SIZE];
  pcap_t* p =
      pcap_open_offline_with_tstamp_precision(path.c_str(), PCAP_TSTAMP_PRECISION_NANO, error);
  ASSERT_NE(p, nullptr) << error;
  EXPECT_EQ(pcap_datalink(p), 147);
  pcap_pkthdr* header;
  const u_char* data;
  ASSERT_EQ(pcap_next_ex(p, &header, &data), 1);
  EXPECT_EQ(header->ts.tv_sec, 1'700'000'000);
  EXPECT_EQ(header->ts.tv_usec, 123'456'789);
  EXPECT_EQ(std::vector<uint8_t>(data, data + header->caplen), hex("01 03 00 00 00 0a c5 cd"));
  ASSERT_EQ(pcap_next_ex(p, &header, &data), 1);
  EXPECT_EQ(header->caplen, 1u);
  EXPECT_EQ(pcap_next_ex(p, &header, &data), PCAP_ERROR_BREAK);
  pcap_close(p);
  std::filesystem::remove(path);
}

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::vector<size_t> packet_lengths(const std::string& path) {
  char error[PCAP_ERRBUF_SIZE];
  pcap_t* p = pcap_open_offline(path.c_str(), error);
  EXPECT_NE(p, nullptr) << error;
  std::vector<size_t> lengths;
  if (!p) return lengths;
  pcap_pkthdr* header;
  const u_char* data;
  int status;
  while ((status = pcap_next_ex(p, &header, &data)) == 1) lengths.push_back(header->caplen);
  EXPECT_EQ(status, PCAP_ERROR_BREAK) << pcap_geterr(p);  // no block libpcap found broken
  pcap_close(p);
  return lengths;
}

// A new pcapng file with its section header and one interface written out.
struct OneInterfaceFile {
  explicit OneInterfaceFile(const char* name)
      : path(temp_path(name)), writer(path), bus(writer.add_interface(147, "bus")) {
    writer.flush();
    header = std::filesystem::file_size(path);
  }
  ~OneInterfaceFile() { std::filesystem::remove(path); }
  uint64_t packet_bytes() const { return std::filesystem::file_size(path) - header; }

  std::string path;
  PcapngWriter writer;
  uint32_t bus;
  uint64_t header = 0;
};

// A held packet keeps itself and all after it in memory; its comment grows in place (past its
// padding, so that the blocks behind it move), and the file stays readable block by block.
TEST(PcapngWriter, HeldPacketsWaitAndTheirCommentsGrowInPlace) {
  OneInterfaceFile file("modtap-held-test.pcapng");
  PcapngWriter& writer = file.writer;
  writer.write_packet(file.bus, 1, hex("01"), PacketDirection::outbound, "held a", 1);
  writer.write_packet(file.bus, 2, hex("02 02"), PacketDirection::outbound, "held b\nline 2", 2);
  writer.write_packet(file.bus, 3, hex("03 03 03"), PacketDirection::inbound, "after");
  writer.flush();
  EXPECT_EQ(file.packet_bytes(), 0u);  // nothing passes the first held packet
  writer.extend_comment(1, " grown by eleven");
  writer.extend_comment(2, "!");
  writer.extend_comment(9, "not held");  // gone or never held: nothing to do
  writer.release(2);
  writer.flush();
  EXPECT_EQ(file.packet_bytes(), 0u);
  writer.release(1);
  writer.flush();
  EXPECT_GT(file.packet_bytes(), 0u);
  writer.close();
  EXPECT_EQ(packet_lengths(file.path), (std::vector<size_t>{1, 2, 3}));
  const std::string text = file_text(file.path);
  EXPECT_NE(text.find("held a grown by eleven"), std::string::npos);
  EXPECT_NE(text.find("held b!\nline 2"), std::string::npos);  // the first line grows
  EXPECT_EQ(text.find("not held"), std::string::npos);
}

// Held packets take bounded memory: past 4,096 of them, or 4 MiB from the first on, the oldest
// goes out as it is.
TEST(PcapngWriter, HoldingIsBounded) {
  OneInterfaceFile file("modtap-held-bound-test.pcapng");
  PcapngWriter& writer = file.writer;
  const uint64_t block = 48;  // 28 fixed, 1 byte of data and 3 of padding, "c" in 8, 8 to end
  for (uint64_t key = 1; key <= 5000; ++key)
    writer.write_packet(file.bus, 0, hex("01"), PacketDirection::unknown, "c", key);
  writer.flush();
  EXPECT_EQ(file.packet_bytes(), (5000 - 4096) * block);
  writer.release_all();
  writer.write_packet(file.bus, 0, hex("01"), PacketDirection::unknown, "c", 1);
  for (int i = 0; i < 100'000; ++i)  // 4.8 MB behind the one held packet
    writer.write_packet(file.bus, 0, hex("01"), PacketDirection::unknown, "c");
  writer.flush();
  EXPECT_GT(file.packet_bytes(), 5000 * block + 95'000 * block);
  writer.close();
  EXPECT_EQ(packet_lengths(file.path).size(), 5000u + 100'001u);
}

TEST(PcapngSink, ExportedPduNamesMbrtuAndPutsTheSlaveOnPort502) {
  const auto path = temp_path("modtap-exported-test.pcapng");
  const std::vector<ChannelInfo> channels{{"bus", ChannelRole::bus}};
  {
    PcapngWriter writer(path);
    output::PcapngOptions options;
    options.link = output::PcapngLink::exported_pdu;
    output::PcapngSink sink(writer, channels, options);
    const auto raw = hex("01 03 02 07 d0 bb e8");
    Frame frame;
    frame.raw = frame.adu = raw;
    frame.role = Role::response;
    frame.check_ok = true;
    sink.on_frame(frame);
  }
  char error[PCAP_ERRBUF_SIZE];
  pcap_t* p = pcap_open_offline(path.c_str(), error);
  ASSERT_NE(p, nullptr) << error;
  EXPECT_EQ(pcap_datalink(p), 252);
  pcap_pkthdr* header;
  const u_char* data;
  ASSERT_EQ(pcap_next_ex(p, &header, &data), 1);
  const std::vector<uint8_t> packet(data, data + header->caplen);
  // tag 12 "mbrtu" padded to 8, port type TCP, source 502, destination 50200, end, ADU.
  EXPECT_EQ(packet, hex("000c 0008 6d 62 72 74 75 00 00 00  0018 0004 00000002  0019 0004 000001f6"
                        "001a 0004 0000c418  0000 0000  01 03 02 07 d0 bb e8"));
  pcap_close(p);
  std::filesystem::remove(path);
}

// A comment says what a reader cannot know: every key where nothing is known, and where the
// packet before, the packet's direction and the line's speed tell a key's value, not that key.
TEST(PcapngSink, CommentsCarryOnlyWhatAReaderCannotKnow) {
  Frame frame;
  const auto raw = hex("01 03 02 07 d0 bb e9");
  frame.raw = frame.adu = raw;
  frame.index = 7;
  frame.role = Role::response;
  frame.check_ok = false;
  frame.expected_check = 0xE8BB;
  frame.request = 6;
  frame.latency_ns = 2'500'000;
  frame.findings = finding_bad_check;
  frame.t_ns = 1'000'000;
  frame.end_ns = 4'645'831;  // 7 bytes of 520,833 ns: what a reread needs to time it again
  EXPECT_EQ(output::frame_comment(frame),
            "modtap index=7 role=response duration_ns=3645831 check=bad expected_check=0xe8bb "
            "latency_us=2500.000 finding=bad-check");
  const output::CommentDefaults after_6{6, Role::response, 520'833};
  EXPECT_EQ(output::frame_comment(frame, after_6),
            "modtap check=bad expected_check=0xe8bb latency_us=2500.000 finding=bad-check");
  frame.end_ns += 1;  // no longer its bytes at the line's speed
  frame.request = 4;  // not the record before
  EXPECT_EQ(output::frame_comment(frame, after_6),
            "modtap duration_ns=3645832 check=bad expected_check=0xe8bb request=4 "
            "latency_us=2500.000 finding=bad-check");
  frame.request.reset();
  frame.latency_ns.reset();
  frame.findings = 0;
  frame.check_ok = true;
  EXPECT_EQ(output::frame_comment(frame, {7, Role::request, 0}),
            "modtap index=7 role=response duration_ns=3645832 request=none");

  const auto exception = hex("01 83 02 c0 f1");
  frame.raw = frame.adu = exception;
  frame.end_ns = frame.t_ns + 5 * 520'833;
  frame.request = 6;
  EXPECT_EQ(output::frame_comment(frame, after_6), "modtap exception=2");
}

// Readers take the verdicts from a comment's first line: a time-out goes there, ahead of a
// device model's note lines.
TEST(PcapngSink, ATimeOutJoinsTheCommentsFirstLineAheadOfTheModelsNotes) {
  const auto path = temp_path("modtap-timeout-note-test.pcapng");
  const std::vector<ChannelInfo> channels{{"bus", ChannelRole::bus}};
  const auto request = hex("01 03 00 00 00 01 84 0a");
  DeviceModel model;
  model.name = "drive";
  Meaning meaning;
  meaning.model = &model;
  meaning.findings.add(RuleKind::unmapped_register, 0x0000, "0000H is in none of its tables");
  Frame frame;
  frame.index = 1;
  frame.role = Role::request;
  frame.raw = frame.adu = request;
  frame.check_ok = true;
  frame.meaning = &meaning;
  {
    PcapngWriter writer(path);
    output::PcapngSink sink(writer, channels, {});
    sink.on_frame(frame);
    sink.on_timeout(silent_time_out(2, 1, 1'000'000'000));
    sink.finish();
    writer.close();
  }
  EXPECT_NE(file_text(path).find("modtap index=1 duration_ns=0 model=drive waited_us=1000000 "
                                 "timeout=silence\nnote unmapped-register: 0000H is in none"),
            std::string::npos)
      << file_text(path);
  std::filesystem::remove(path);
}

// A comment renders the record's field walk: its keys are the field registry's names (the
// plugin's modtap.NAME), but for what only a packet says: its duration, an untimed start, one
// key a finding, and what noise is or why a request timed out.
TEST(PcapngSink, ACommentsKeysAreTheFieldRegistrysNames) {
  std::set<std::string_view> names{"duration_ns", "untimed_start", "finding", "noise", "timeout"};
  for (const FieldInfo& field : field_registry()) names.insert(field.name);
  Frame frame;
  const auto raw = hex("01 83 02 c0 f2");
  frame.raw = frame.adu = raw;
  frame.index = 7;
  frame.mode = Mode::ascii;
  frame.role = Role::response;
  frame.damage = Damage::corrupted;
  frame.findings = finding_bad_check | finding_unsolicited;
  frame.latency_ns = 1000;
  frame.untimed_start = true;
  Noise noise;
  noise.raw = raw;
  noise.request = 3;
  Timeout timeout;
  timeout.reason = TimeoutReason::silence;
  fmt::memory_buffer waited;
  output::append_timeout_comment(waited, timeout);
  const std::string comments =
      output::frame_comment(frame) + " " + output::noise_comment(noise) + fmt::to_string(waited);
  size_t keys = 0;
  for (size_t equals = comments.find('='); equals != std::string::npos;
       equals = comments.find('=', equals + 1), ++keys) {
    const size_t space = comments.rfind(' ', equals);
    const std::string_view key(comments.data() + space + 1, equals - space - 1);
    EXPECT_TRUE(names.contains(key)) << key << " in " << comments;
  }
  EXPECT_GE(keys, 16u) << comments;
}

// A request that timed out says so in its own comment: the sink holds it, and what follows it,
// until its outcome is known, and writes everything in order.
// A latency or a wait has no more digits than the clock tells: microseconds where a packet's or
// a read's time stamp is the clock, nanoseconds where each byte is timed.
TEST(PcapngSink, TimesAreWrittenToTheClocksResolution) {
  const auto response = hex("01 03 02 00 07 f9 86");
  Frame f;
  f.index = 2;
  f.role = Role::response;
  f.raw = f.adu = response;
  f.check_ok = true;
  f.request = 1;
  f.latency_ns = 6'877'084;
  output::CommentDefaults defaults{1, Role::response, 0};
  const auto latency = [&] {
    const std::string comment = output::frame_comment(f, defaults);
    return comment.substr(comment.find(" latency_us="));
  };
  defaults.resolution_ns = 1000;
  EXPECT_EQ(latency(), " latency_us=6877");
  defaults.resolution_ns = 1;
  EXPECT_EQ(latency(), " latency_us=6877.084");
}

TEST(PcapngSink, ARequestThatTimedOutSaysSoAndOrderIsKept) {
  const auto path = temp_path("modtap-timeout-test.pcapng");
  const std::vector<ChannelInfo> channels{{"bus", ChannelRole::bus}};
  const auto request = hex("01 03 00 00 00 01 84 0a");
  const auto answer = hex("02 03 02 00 07 7c 46");
  auto frame = [&](uint64_t index, Role role, std::span<const uint8_t> raw) {
    Frame f;
    f.index = index;
    f.role = role;
    f.raw = f.adu = raw;
    f.check_ok = true;
    f.t_ns = f.end_ns = static_cast<int64_t>(index) * 1'000'000;
    return f;
  };
  {
    PcapngWriter writer(path);
    output::PcapngSink sink(writer, channels, {});
    sink.on_frame(frame(1, Role::request, request));  // slave 1 never answers
    Noise noise;
    noise.index = 2;
    const auto junk = hex("ff");
    noise.raw = junk;
    sink.on_noise(noise);
    sink.on_timeout(silent_time_out(3, 1, 1'000'000'123));
    sink.on_frame(frame(4, Role::request, request));
    auto response = frame(5, Role::response, answer);
    response.request = 4;
    sink.on_frame(response);
    sink.on_frame(frame(6, Role::request, request));  // the capture ends first
    sink.finish();
    writer.close();
  }
  char error[PCAP_ERRBUF_SIZE];
  pcap_t* p = pcap_open_offline(path.c_str(), error);
  ASSERT_NE(p, nullptr) << error;
  pcap_pkthdr* header;
  const u_char* data;
  std::vector<size_t> lengths;
  while (pcap_next_ex(p, &header, &data) == 1) lengths.push_back(header->caplen);
  pcap_close(p);
  EXPECT_EQ(lengths, (std::vector<size_t>{8, 1, 8, 7, 8}));
  const std::string file = [&] {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  // A packet's time stamp tells microseconds: the wait is written to them.
  EXPECT_NE(file.find("modtap index=1 duration_ns=0 waited_us=1000000 timeout=silence"),
            std::string::npos);
  EXPECT_EQ(file.find("timeout=", file.find("index=4 ")), std::string::npos);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace modtap::captures
