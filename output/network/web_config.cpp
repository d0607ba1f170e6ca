#include "output/network/web_config.hpp"

#include <crypt.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "decoder/models/yaml_tree.hpp"

namespace modtap::output {
namespace {

std::runtime_error problem(const std::string& path, unsigned line, std::string_view what) {
  return std::runtime_error(fmt::format("--metrics-web-config {}:{}: {}", path, line, what));
}

std::string read_text(const std::string& path, const std::string& why) {
  std::ifstream file(path, std::ios::binary);
  std::ostringstream text;
  if (!file || !(text << file.rdbuf()))
    throw std::runtime_error(fmt::format("{}: cannot read {}", why, path));
  return text.str();
}

// The toolkit's keys modtap serves; any other (client certificates, cipher lists, headers) is
// refused by name rather than ignored, so a configuration never promises what is not done.
void read_tls(const std::string& path, const YamlNode& tls, WebConfig& config) {
  if (!tls.is_map()) throw problem(path, tls.line(), "tls_server_config must be a map");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  for (const auto& [key, value] : tls.entries()) {
    if (key.text() != "cert_file" && key.text() != "key_file")
      throw problem(
          path, key.line(),
          fmt::format("tls_server_config: {} is not supported (cert_file, key_file)", key.text()));
    if (!value.is_scalar() || value.text().empty())
      throw problem(path, value.line(), fmt::format("{} must name a file", key.text()));
    const std::string file = (folder / value.text()).string();
    const std::string where = fmt::format("--metrics-web-config {}:{}", path, value.line());
    (key.text() == "cert_file" ? config.cert_pem : config.key_pem) = read_text(file, where);
  }
  if (config.cert_pem.empty() || config.key_pem.empty())
    throw problem(path, tls.line(), "tls_server_config needs both cert_file and key_file");
}

// "$2b$" and the highest cost ("10"; two digits, as every bcrypt hash gives it) of the users'
// hashes, then a salt and checksum of zero bits.
std::string stand_in_hash(const std::map<std::string, std::string>& users) {
  std::string cost = "04";
  for (const auto& [name, hash] : users)
    if (hash.size() > 6 && hash[6] == '$') cost = std::max(cost, hash.substr(4, 2));
  return "$2b$" + cost + "$" + std::string(53, '.');
}

void read_users(const std::string& path, const YamlNode& users, WebConfig& config) {
  if (!users.is_map()) throw problem(path, users.line(), "basic_auth_users must be a map");
  for (const auto& [name, hash] : users.entries()) {
    const std::string& text = hash.text();
    if (!hash.is_scalar() ||
        !(text.starts_with("$2a$") || text.starts_with("$2b$") || text.starts_with("$2y$")))
      throw problem(path, hash.line(),
                    fmt::format("the password of {} is not a bcrypt hash ($2b$...; htpasswd -nB)",
                                name.text()));
    config.users[name.text()] = text;
  }
  config.stand_in_hash = stand_in_hash(config.users);
}

}  // namespace

WebConfig read_web_config(const std::string& path) {
  const std::string text = read_text(path, "--metrics-web-config");
  YamlNode root;
  try {
    root = parse_yaml(text);
  } catch (const YamlSyntaxError& e) {
    throw problem(path, e.line(), e.what());
  }
  WebConfig config;
  if (root.is_null()) return config;
  if (!root.is_map()) throw problem(path, root.line(), "not a map of settings");
  for (const auto& [key, value] : root.entries()) {
    if (key.text() == "tls_server_config")
      read_tls(path, value, config);
    else if (key.text() == "basic_auth_users")
      read_users(path, value, config);
    else
      throw problem(
          path, key.line(),
          fmt::format("{} is not supported (tls_server_config, basic_auth_users)", key.text()));
  }
  return config;
}

bool password_matches(std::string_view password, const std::string& hash) {
  crypt_data data{};
  const std::string given(password);
  const char* result = crypt_rn(given.c_str(), hash.c_str(), &data, sizeof data);
  if (!result || result[0] == '*') return false;
  return same_secret(result, hash);
}

bool same_secret(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char differ = 0;
  for (size_t i = 0; i < a.size(); ++i) differ |= static_cast<unsigned char>(a[i] ^ b[i]);
  return differ == 0;
}

}  // namespace modtap::output
