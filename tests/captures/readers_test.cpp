#include <gtest/gtest.h>
#include <pcap/pcap.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "captures/hexlog_reader.hpp"
#include "captures/open_capture.hpp"
#include "captures/pcap_reader.hpp"
#include "captures/pcapng_writer.hpp"
#include "captures/raw_reader.hpp"
#include "tests/support/collector.hpp"

namespace modtap::captures {
namespace {

namespace fs = std::filesystem;
using testing::hex;

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("modtap-test-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

 public:
  std::string write_file(const std::string& name, const std::string& content) {
    return write(name, content);
  }

 protected:
  std::string write(const std::string& name, const std::string& content) {
    const auto path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }
  std::string write_pcap(const std::string& name, int dlt,
                         const std::vector<std::vector<uint8_t>>& packets) {
    const auto path = (dir_ / name).string();
    pcap_t* dead = pcap_open_dead(dlt, 65535);
    pcap_dumper_t* dumper = pcap_dump_open(dead, path.c_str());
    for (size_t i = 0; i < packets.size(); ++i) {
      pcap_pkthdr h{};
      h.ts.tv_sec = 1700000000;
      h.ts.tv_usec = static_cast<suseconds_t>(i * 1000);
      h.caplen = h.len = static_cast<bpf_u_int32>(packets[i].size());
      pcap_dump(reinterpret_cast<u_char*>(dumper), &h, packets[i].data());
    }
    pcap_dump_close(dumper);
    pcap_close(dead);
    return path;
  }
  fs::path dir_;
};

std::string error_of(const std::string& path, Format format = Format::automatic) {
  try {
    OpenOptions o;
    o.format = format;
    auto source = open_capture(path, o);
    Chunk chunk;
    while (source->next(chunk)) {
    }
  } catch (const CaptureError& e) {
    return e.what();
  }
  return "";
}

TEST_F(TempDir, HexlogReadsJpnevulatorBlocksAndTtyNames) {
  const auto path = write("bus.log",
                          "2026-11-22 10:57:33.761949: /dev/ttyUSB0\n"
                          "01 03 00 00 00 0A C5 CD                        \t........\n"
                          "2026-11-22 10:57:33.963377: /dev/ttyUSB1\n"
                          "01 03 02 00 0A 38 43");
  HexlogReader reader(path, 1000);
  Chunk chunk;
  ASSERT_TRUE(reader.next(chunk));
  EXPECT_EQ(std::vector<uint8_t>(chunk.bytes.begin(), chunk.bytes.end()),
            hex("01 03 00 00 00 0a c5 cd"));
  EXPECT_EQ(chunk.channel, 0);
  const int64_t first = chunk.t_ns;
  ASSERT_TRUE(reader.next(chunk));
  EXPECT_EQ(chunk.channel, 1);
  EXPECT_EQ(chunk.t_ns - first, 201'428'000);  // each block ends at its stamp
  EXPECT_FALSE(reader.next(chunk));
  ASSERT_EQ(reader.channels().size(), 2u);
  EXPECT_EQ(reader.channels()[1].name, "/dev/ttyUSB1");
}

// jpnevulator stamps a block when its first read returns, after the bytes: a block is read as
// one read ending at its stamp, its lines continuing it (no silence known inside).
TEST_F(TempDir, HexlogBlockIsOneReadEndingAtItsStamp) {
  const auto path = write("block.log",
                          "2026-11-22 10:57:33.000100:\n"
                          "00000000\t01 03 00 00 00 0A C5 CD 01 03 14 00 00 00 00 00\t........\n"
                          "00000010\t00 00\t..\n");
  HexlogReader reader(path, 1000);
  Chunk first, second;
  ASSERT_TRUE(reader.next(first));
  ASSERT_TRUE(reader.next(second));
  EXPECT_EQ(first.bytes.size(), 16u);  // --byte-count's and --ascii's columns left out
  EXPECT_EQ(second.bytes.size(), 2u);
  EXPECT_EQ(second.t_ns - first.t_ns, 2000);
  EXPECT_EQ(second.t_ns % 1'000'000'000, 100'000);
  EXPECT_FALSE(first.continues_read);
  EXPECT_TRUE(second.continues_read);
}

// With jpnevulator's default --timing-delta, a block gathers every read within 100 ms of the one
// before: placed to end at its stamp it would begin before the block before it ended. It
// follows that block instead, the silence between them unknown.
TEST_F(TempDir, HexlogBlockOfSeveralReadsFollowsTheOneBefore) {
  const auto path = write("merged.log",
                          "2026-11-22 10:57:33.000100:\n"
                          "01 03 00 00 00 0A C5 CD\n"
                          "2026-11-22 10:57:33.000105:\n"
                          "01 03 14 00 00 00 00 00 00 00 00 00 00 00 00 00\n");
  HexlogReader reader(path, 1000);
  Chunk request, answer;
  ASSERT_TRUE(reader.next(request));
  ASSERT_TRUE(reader.next(answer));
  EXPECT_EQ(request.t_ns % 1'000'000'000, 100'000);
  EXPECT_FALSE(request.continues_read);
  EXPECT_EQ(answer.t_ns - request.t_ns, 16'000);
  EXPECT_TRUE(answer.continues_read);
}

TEST_F(TempDir, HexlogWithABrokenLineNamesTheLine) {
  const auto path = write("bad.log", "2026-11-22 10:57:33.761949:\n01 03 zz 00\n");
  EXPECT_EQ(error_of(path), path + ": line 2, column 7: expected a hex byte, found \"zz 00\"");
}

TEST_F(TempDir, HexlogBytesBeforeAnyTimeStampAreAnError) {
  const auto path = write("nostamp.log", "01 03\n");
  EXPECT_NE(error_of(path, Format::hexlog).find("line 1: bytes before the first time stamp"),
            std::string::npos);
}

TEST_F(TempDir, PcapPacketsBecomeTimedChunks) {
  const auto path = write_pcap("user0.pcap", 147, {hex("01 03 00 00"), hex("00 0a c5 cd")});
  PcapReader reader(path);
  Chunk chunk;
  ASSERT_TRUE(reader.next(chunk));
  EXPECT_EQ(chunk.t_ns, 1700000000LL * 1'000'000'000);
  ASSERT_TRUE(reader.next(chunk));
  EXPECT_EQ(chunk.t_ns, 1700000000LL * 1'000'000'000 + 1'000'000);
  EXPECT_EQ(chunk.bytes.size(), 4u);
  EXPECT_FALSE(reader.next(chunk));
}

// Written by hand: big-endian, nanosecond time stamps (magic a1b23c4d), then a record whose
// length lies.
TEST_F(TempDir, PcapInTheOtherByteOrderWithNanosecondsReads) {
  std::string file;
  const auto be32 = [&](uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) file.push_back(static_cast<char>(v >> shift));
  };
  be32(0xA1B23C4D);
  be32(0x00020004);  // version 2.4
  be32(0);
  be32(0);
  be32(65535);
  be32(147);  // DLT_USER0
  be32(1700000000);
  be32(123'456'789);  // nanoseconds
  be32(3);
  be32(3);
  file += std::string("\x01\x03\x00", 3);
  be32(1700000001);
  be32(0);
  be32(0x7FFF'FFFF);  // a length no packet has
  be32(0x7FFF'FFFF);
  const auto path = write("be.pcap", file);
  PcapReader reader(path);
  Chunk chunk;
  ASSERT_TRUE(reader.next(chunk));
  EXPECT_EQ(chunk.t_ns, 1700000000LL * 1'000'000'000 + 123'456'789);
  EXPECT_EQ(chunk.bytes.size(), 3u);
  EXPECT_EQ(chunk.bytes[1], 0x03);
  try {
    reader.next(chunk);
    FAIL() << "no error";
  } catch (const CaptureError& e) {
    EXPECT_EQ(std::string(e.what()),
              path +
                  ": offset 43, after packet 1: a packet of 2147483647 bytes, more than 262144: "
                  "its length is damaged");
  }
}

TEST_F(TempDir, PcapOfAnotherLinkTypeIsRefused) {
  const auto path = write_pcap("eth.pcap", 1, {hex("00")});
  EXPECT_NE(error_of(path).find("link type 1 (Ethernet) does not carry serial bytes"),
            std::string::npos);
}

TEST_F(TempDir, TruncatedPcapNamesTheOffset) {
  const auto good = write_pcap("whole.pcap", 147,
                               {hex("01 03 00 00 00 0a c5 cd"), hex("01 03 00 00 00 0a c5 cd")});
  std::ifstream in(good, std::ios::binary);
  std::string content((std::istreambuf_iterator<char>(in)), {});
  const auto path = write("cut.pcap", content.substr(0, content.size() - 5));
  const std::string error = error_of(path);
  EXPECT_NE(error.find(path + ": offset 48, after packet 1: truncated"), std::string::npos)
      << error;
}

// Reads `content` cut at every offset: each cut reads up to a packet and then either ends
// (a cut between packets) or names the file and offset; never more bytes than the whole.
void expect_every_cut_is_clear(TempDir& dir, const std::string& name, const std::string& content,
                               size_t whole_bytes) {
  for (size_t cut = 1; cut < content.size(); ++cut) {
    const auto path = dir.write_file(name, content.substr(0, cut));
    size_t bytes = 0;
    try {
      PcapReader reader(path);
      Chunk chunk;
      while (reader.next(chunk)) bytes += chunk.bytes.size();
    } catch (const CaptureError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": offset ", 0), 0u) << cut << ": " << e.what();
    }
    EXPECT_LE(bytes, whole_bytes) << cut;
  }
}

TEST_F(TempDir, APcapCutAtEveryOffsetReadsUpToTheCutOrNamesTheOffset) {
  const auto good = write_pcap("whole.pcap", 147,
                               {hex("01 03 00 00 00 0a c5 cd"), hex("01 03 14 00 01 00 02"),
                                hex("00 03 00 04 00 05 00 06 00 07 00 08 00 09 00 0a 8f 16")});
  std::ifstream in(good, std::ios::binary);
  expect_every_cut_is_clear(*this, "cut.pcap", {std::istreambuf_iterator<char>(in), {}}, 33);
}

TEST_F(TempDir, APcapngCutAtEveryOffsetReadsUpToTheCutOrNamesTheOffset) {
  const auto path = (dir_ / "whole.pcapng").string();
  {
    PcapngWriter writer(path);
    const uint32_t tx = writer.add_interface(147, "tx"), rx = writer.add_interface(147, "rx");
    writer.write_packet(tx, 1'700'000'000'000'000'000, hex("01 03 00 00 00 0a c5 cd"),
                        PacketDirection::outbound, "request");
    writer.write_packet(rx, 1'700'000'000'010'000'000, hex("01 83 02 c0 f1"),
                        PacketDirection::inbound, "");
    writer.close();
  }
  std::ifstream in(path, std::ios::binary);
  expect_every_cut_is_clear(*this, "cut.pcapng", {std::istreambuf_iterator<char>(in), {}}, 13);
}

TEST_F(TempDir, APacketLengthThatLiesIsAnErrorNotAnAllocation) {
  const auto good = write_pcap("whole.pcap", 147, {hex("01 03 00 00 00 0a c5 cd")});
  std::ifstream in(good, std::ios::binary);
  std::string content{std::istreambuf_iterator<char>(in), {}};
  // The record header after the 24-byte file header: ts_sec, ts_usec, caplen, len.
  for (const uint32_t lie : {0x7FFFFFFFu, 9u, 0xFFFFFFFFu}) {
    std::memcpy(content.data() + 24 + 8, &lie, 4);
    const auto path = write("lying.pcap", content);
    EXPECT_EQ(error_of(path).rfind(path + ": offset", 0), 0u) << lie << ": " << error_of(path);
  }
}

TEST_F(TempDir, UnknownContentWithAnUnknownNameIsAnError) {
  const auto path = write("mystery.dat", "\x01\x03");
  EXPECT_NE(error_of(path).find("cannot tell the capture format"), std::string::npos);
}

TEST_F(TempDir, MissingFileIsAnError) {
  EXPECT_NE(error_of((dir_ / "absent.pcap").string()).find("cannot open"), std::string::npos);
}

TEST_F(TempDir, FormatIsToldByContentBeforeName) {
  const auto pcap = write_pcap("looks-raw.bin", 147, {hex("01")});
  EXPECT_EQ(detect_format(pcap), Format::pcap);
  EXPECT_EQ(detect_format(write("x.bin", "\x01\x02")), Format::raw);
  EXPECT_EQ(detect_format(write("x.txt", "2026-11-22 10:57:33.761949:\n01\n")), Format::hexlog);
}

TEST_F(TempDir, RawReaderDeliversEveryByteUntimed) {
  std::string content(200000, '\x5a');
  RawReader reader(write("big.bin", content));
  Chunk chunk;
  size_t total = 0;
  while (reader.next(chunk)) total += chunk.bytes.size();
  EXPECT_EQ(total, content.size());
  EXPECT_EQ(reader.clock(), ClockQuality::none);
}

}  // namespace
}  // namespace modtap::captures
