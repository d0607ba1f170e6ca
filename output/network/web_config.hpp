// --metrics-web-config: TLS and users for the metrics server, in the format of the Prometheus
// exporter toolkit (node_exporter's --web.config.file), so a plant's Prometheus setup carries
// over as it is:
//
//   tls_server_config: {cert_file: metrics.pem, key_file: metrics.key}
//   basic_auth_users: {prometheus: $2b$10$...}   # bcrypt hashes (htpasswd -B, mkpasswd)
//
// Relative file names are from the configuration's folder, as the toolkit reads them.
#pragma once

#include <map>
#include <string>
#include <string_view>

namespace modtap::output {

struct WebConfig {
  std::string cert_pem, key_pem;             // both empty: plain HTTP
  std::map<std::string, std::string> users;  // name -> bcrypt hash; none: no authentication
  // A bcrypt hash as costly as the users' costliest, that no password matches: a name no user
  // has is checked against it, so the answer takes as long as for a user's wrong password and
  // does not tell a stranger which names exist.
  std::string stand_in_hash;
  bool tls() const { return !cert_pem.empty(); }
};

// Throws std::runtime_error naming the file and line of the first problem.
WebConfig read_web_config(const std::string& path);

// Whether `password` is the one `hash` (bcrypt, checked by the system's crypt library) holds.
bool password_matches(std::string_view password, const std::string& hash);
// Whether two secrets are equal, compared in full whatever differs first: the time taken says
// nothing of where they differ.
bool same_secret(std::string_view a, std::string_view b);

}  // namespace modtap::output
