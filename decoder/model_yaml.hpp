// Reads a device model from its YAML text (the format is docs/dictionaries.md). Parsing only:
// the caller reads the file, so this stays free of I/O.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/device_model.hpp"

namespace modtap::decoder {

// Every problem found in one file, each as "FILE:LINE: message".
class ModelError : public std::runtime_error {
 public:
  explicit ModelError(std::vector<std::string> problems);
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

// The name of the model a file extends, or "" (so a catalog can load bases first).
std::string model_base(std::string_view yaml, const std::string& file);

// `base` is the model named by `extends:`, or null. Throws ModelError.
DeviceModel parse_model(std::string_view yaml, const std::string& file,
                        const DeviceModel* base = nullptr);

}  // namespace modtap::decoder
