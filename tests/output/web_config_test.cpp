#include "output/network/web_config.hpp"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace modtap::output {
namespace {

// "pw" under bcrypt, cost 10 (Python's crypt.crypt with METHOD_BLOWFISH).
const std::string pw_hash = "$2b$10$x5s7zqPbIqztUW8RkiqZAehb4yXz2ApBCyFCR.XjTMfXHGm6nxza6";

std::string write(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream(path) << text;
  return path.string();
}

std::string problem_of(const std::string& path) {
  try {
    read_web_config(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(WebConfig, BcryptPasswordsAreCheckedByTheSystemsCrypt) {
  EXPECT_TRUE(password_matches("pw", pw_hash));
  EXPECT_FALSE(password_matches("pW", pw_hash));
  EXPECT_FALSE(password_matches("", pw_hash));
  EXPECT_FALSE(password_matches("pw", "$2b$10$not-a-hash"));
  EXPECT_TRUE(same_secret("abc", "abc"));
  EXPECT_FALSE(same_secret("abc", "abd"));
  EXPECT_FALSE(same_secret("abc", "abcd"));
}

TEST(WebConfig, ReadsTheToolkitsKeysWithFilesBesideIt) {
  write("modtap-web-cert.pem", "CERT");
  write("modtap-web-key.pem", "KEY");
  const WebConfig config = read_web_config(
      write("modtap-web.yml",
            "tls_server_config:\n  cert_file: modtap-web-cert.pem\n  key_file: modtap-web-key.pem\n"
            "basic_auth_users:\n  prometheus: '" +
                pw_hash + "'\n"));
  EXPECT_TRUE(config.tls());
  EXPECT_EQ(config.cert_pem, "CERT");
  EXPECT_EQ(config.key_pem, "KEY");
  ASSERT_EQ(config.users.size(), 1u);
  EXPECT_EQ(config.users.at("prometheus"), pw_hash);
}

// A name no user has is checked against a hash of the users' cost: the answer takes as long as
// a known user's wrong password, so its speed tells a stranger nothing of which names exist.
TEST(WebConfig, ANameNoUserHasCostsAsMuchAsAWrongPassword) {
  const WebConfig config = read_web_config(
      write("modtap-web-users.yml", "basic_auth_users:\n  prometheus: '" + pw_hash + "'\n"));
  EXPECT_EQ(config.stand_in_hash.substr(0, 7), "$2b$10$");
  const auto fastest_check = [](const std::string& hash) {
    auto fastest = std::chrono::steady_clock::duration::max();
    for (int i = 0; i < 3; ++i) {
      const auto start = std::chrono::steady_clock::now();
      EXPECT_FALSE(password_matches("guess", hash));
      fastest = std::min(fastest, std::chrono::steady_clock::now() - start);
    }
    return fastest;
  };
  const auto wrong_password = fastest_check(pw_hash),
             no_such_user = fastest_check(config.stand_in_hash);
  // The same order of time (a refused hash would answer in microseconds, a thousandth of it).
  EXPECT_GT(no_such_user * 4, wrong_password);
  EXPECT_GT(wrong_password * 4, no_such_user);
}

TEST(WebConfig, ProblemsNameTheFileAndLine) {
  const std::string unknown =
      write("modtap-web-unknown.yml", "basic_auth_users: {}\nheaders: {}\n");
  EXPECT_EQ(problem_of(unknown), "--metrics-web-config " + unknown +
                                     ":2: headers is not supported (tls_server_config, "
                                     "basic_auth_users)");
  const std::string plain = write("modtap-web-plain.yml", "basic_auth_users:\n  me: secret\n");
  EXPECT_NE(problem_of(plain).find(plain + ":2: the password of me is not a bcrypt hash"),
            std::string::npos)
      << problem_of(plain);
  const std::string half = write("modtap-web-half.yml", "tls_server_config:\n  cert_file: x.pem\n");
  EXPECT_NE(problem_of(half).find("x.pem"), std::string::npos) << problem_of(half);
  EXPECT_NE(problem_of("/nonexistent/web.yml").find("cannot read /nonexistent/web.yml"),
            std::string::npos);
}

}  // namespace
}  // namespace modtap::output
