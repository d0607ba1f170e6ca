#include "captures/com_port_option.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

namespace modtap::captures {
namespace {

using Bytes = std::vector<uint8_t>;

// 9600 8N1: WILL COM-PORT-OPTION, binary both ways, then each setting in its subnegotiation.
TEST(ComPortOption, TheOpeningSetsThePortAndSendsNoDataByte) {
  const Bytes opening = ComPortOption::opening({9600, 8, Parity::none, 1});
  const Bytes expected = {255, 251, 44, 255, 251, 0,   255,  253,  0,         // options
                          255, 250, 44, 1,   0,   0,   0x25, 0x80, 255, 240,  // baud 9600
                          255, 250, 44, 2,   8,   255, 240,                   // 8 data bits
                          255, 250, 44, 3,   1,   255, 240,                   // no parity
                          255, 250, 44, 4,   1,   255, 240};                  // 1 stop bit
  EXPECT_EQ(opening, expected);
}

// A baud whose bytes hold 0xFF has it doubled inside the subnegotiation.
TEST(ComPortOption, AValueByteOf0xFFIsDoubled) {
  const Bytes opening = ComPortOption::opening({0x0001'FFFF, 8, Parity::even, 1});
  const Bytes baud = {255, 250, 44, 1, 0, 1, 255, 255, 255, 255, 255, 240};
  EXPECT_NE(std::search(opening.begin(), opening.end(), baud.begin(), baud.end()), opening.end());
}

// What the server sends, cut anywhere: its data bytes come out with a doubled 0xFF undone, its
// commands never; an option it offers or asks for is refused, its answers to ours are not; the
// settings it reports are kept.
TEST(ComPortOption, TheServersCommandsLeaveOnlyTheLinesBytes) {
  const Bytes stream = {255,  253,  44,              // DO COM-PORT-OPTION: ours
                        255,  251,  1,               // WILL ECHO: refused
                        0x01, 0x03, 255, 255, 0x02,  // data, a 0xFF doubled
                        255,  253,  3,               // DO SUPPRESS-GO-AHEAD: refused
                        255,  250,  44,  101, 0,    0,   0x4B, 0x00, 255, 240,  // its baud: 19200
                        0x04,                                                   // data
                        255,  250,  44,  102, 8,    255, 240,                   // 8 data bits
                        255,  250,  44,  103, 3,    255, 240,                   // even parity
                        255,  241,                                              // NOP
                        255,  250,  44,  104, 1,    255, 240,                   // 1 stop bit
                        0x05};
  for (size_t cut = 0; cut <= stream.size(); ++cut) {
    ComPortOption telnet;
    Bytes data, replies;
    telnet.take({stream.data(), cut}, data, replies);
    telnet.take({stream.data() + cut, stream.size() - cut}, data, replies);
    EXPECT_EQ(data, (Bytes{0x01, 0x03, 0xFF, 0x02, 0x04, 0x05})) << "cut at " << cut;
    EXPECT_EQ(replies, (Bytes{255, 254, 1, 255, 252, 3})) << "cut at " << cut;
    EXPECT_EQ(telnet.reported().baud, 19200u);
    EXPECT_EQ(telnet.reported().data_bits, 8);
    EXPECT_EQ(telnet.reported().parity, Parity::even);
    EXPECT_EQ(telnet.reported().stop_bits, 1);
    EXPECT_FALSE(telnet.refused());
  }
}

TEST(ComPortOption, AServerThatRefusesTheOptionSaysSo) {
  ComPortOption telnet;
  Bytes data, replies;
  telnet.take(Bytes{255, 254, 44, 0x01}, data, replies);
  EXPECT_TRUE(telnet.refused());
  EXPECT_EQ(data, Bytes{0x01});
  EXPECT_TRUE(replies.empty());
}

}  // namespace
}  // namespace modtap::captures
