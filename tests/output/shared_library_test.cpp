#include "output/network/shared_library.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <stdexcept>

namespace modtap::output {
namespace {

using ::testing::HasSubstr;

TEST(SharedLibrary, AMissingLibraryNamesTheOptionAndThePackage) {
  try {
    SharedLibrary("libmodtap-absent.so.7", "--mqtt", "libmodtap-absent7");
    FAIL() << "loaded a library that is not there";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("--mqtt needs libmodtap-absent.so.7 (Debian package "
                                    "libmodtap-absent7)"));
  }
}

TEST(SharedLibrary, AFunctionIsCalledWithItsDeclaredType) {
  const SharedLibrary libc("libc.so.6", "a test", "libc6");
  const auto length = MODTAP_SYMBOL(libc, strlen);
  EXPECT_EQ(length("modtap"), 6u);
  EXPECT_THAT([&] { libc.find("modtap_absent_function"); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  HasSubstr("libc.so.6 has no modtap_absent_function")));
}

}  // namespace
}  // namespace modtap::output
