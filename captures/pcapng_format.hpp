// The numbers of the pcapng format (draft-ietf-opsawg-pcapng) that modtap writes and reads,
// in one place for the writer and the reader.
#pragma once

#include <cstdint>
#include <string_view>

namespace modtap::captures::pcapng {

// Block types.
inline constexpr uint32_t section_header_block = 0x0A0D0D0A;
inline constexpr uint32_t interface_description_block = 1;
inline constexpr uint32_t obsolete_packet_block = 2;
inline constexpr uint32_t simple_packet_block = 3;
inline constexpr uint32_t enhanced_packet_block = 6;
inline constexpr uint32_t byte_order_magic = 0x1A2B3C4D;

// Option codes: the common ones, then per block.
inline constexpr uint16_t opt_endofopt = 0;
inline constexpr uint16_t opt_comment = 1;
inline constexpr uint16_t shb_userappl = 4;
inline constexpr uint16_t if_name = 2;
inline constexpr uint16_t if_tsresol = 9;
inline constexpr uint16_t epb_flags = 2;

// Link types modtap carries serial bytes in: DLT_USER0..15, and Wireshark's exported PDUs.
inline constexpr int first_user_dlt = 147;
inline constexpr int last_user_dlt = 162;
inline constexpr int exported_pdu_dlt = 252;

// What a capture of another link type holds, for the message that refuses it: the ones a
// serial tap's user is likely to pick up by mistake (www.tcpdump.org/linktypes.html).
constexpr std::string_view link_type_name(int link_type) {
  switch (link_type) {
    case 1:
      return "Ethernet";
    case 101:
      return "raw IP";
    case 105:
      return "IEEE 802.11";
    case 113:
      return "Linux cooked";
    case 127:
      return "IEEE 802.11 radiotap";
    case 189:
      return "Linux USB";
    case 220:
      return "Linux USB, memory-mapped";
    case 249:
      return "USBPcap";
    case 276:
      return "Linux cooked v2";
    default:
      return "unknown";
  }
}

// How modtap means the times it writes, said at the start of each interface's comment, so that
// modtap reads its own files back to the same records.
inline constexpr std::string_view interface_convention =
    "modtap: a packet is stamped at the start of its first byte; its comment's duration_ns "
    "runs to the end of its last byte;";

}  // namespace modtap::captures::pcapng
