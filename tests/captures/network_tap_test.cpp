#include "captures/network_tap.hpp"

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

#include "captures/chunk_source.hpp"

namespace modtap::captures {
namespace {

std::string error_of(const std::string& url) {
  try {
    NetworkTap tap(url, SerialFormat{});
  } catch (const CaptureError& e) {
    return e.what();
  }
  return "";
}

TEST(NetworkTap, AnAddressWithoutHostOrPortIsRefusedByName) {
  for (const char* url :
       {"tcp://plc", "tcp://plc:", "tcp://:4001", "tcp://plc:40a1", "tcp://[::1]", "rfc2217://plc"})
    EXPECT_EQ(error_of(url),
              std::string(url) + ": a device server is tcp://HOST:PORT or rfc2217://HOST:PORT");
}

// A port nobody listens on (one the kernel just handed out, and free again) is refused, by name.
TEST(NetworkTap, APortNobodyListensOnIsRefused) {
  const int probe = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(probe, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  socklen_t size = sizeof address;
  getsockname(probe, reinterpret_cast<sockaddr*>(&address), &size);
  close(probe);  // the port is free again, and ephemeral
  const std::string url = "tcp://127.0.0.1:" + std::to_string(ntohs(address.sin_port));
  EXPECT_EQ(error_of(url), url + ": cannot connect: Connection refused");
}

TEST(NetworkTap, AnAddressOfBothKindsIsANetworkTap) {
  EXPECT_TRUE(is_network_tap("tcp://plc:4001"));
  EXPECT_TRUE(is_network_tap("rfc2217://plc:4001"));
  EXPECT_TRUE(sets_server_port("rfc2217://plc:4001"));
  EXPECT_FALSE(sets_server_port("tcp://plc:4001"));
  EXPECT_FALSE(is_network_tap("/dev/ttyUSB0"));
}

}  // namespace
}  // namespace modtap::captures
