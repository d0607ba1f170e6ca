// Reads a device model from its YAML text (the format is docs/dictionaries.md). Parsing only:
// the caller reads the file, so this stays free of I/O.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/models/device_model.hpp"

namespace modtap {

// Every problem found in one file, each as "FILE:LINE: message".
class ModelError : public std::runtime_error {
 public:
  explicit ModelError(std::vector<std::string> problems);
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

// A model file's YAML, parsed once: what it extends, then the model (YAML parsing is most of
// modtap's start, so a catalog that loads bases first must not parse a file twice).
class ModelFile {
 public:
  ModelFile(std::string_view yaml, std::string file);  // throws ModelError on bad YAML
  ModelFile(ModelFile&&) noexcept;
  ModelFile& operator=(ModelFile&&) noexcept;
  ~ModelFile();

  const std::string& file() const { return file_; }
  // The name of the model it extends, or "".
  const std::string& base() const { return base_; }
  // `base` is the model named by `extends:`, or null. Throws ModelError.
  DeviceModel model(const DeviceModel* base) const;

 private:
  struct Document;
  std::unique_ptr<Document> document_;
  std::string file_;
  std::string base_;
};

// The same for a single use.
std::string model_base(std::string_view yaml, const std::string& file);
DeviceModel parse_model(std::string_view yaml, const std::string& file,
                        const DeviceModel* base = nullptr);

}  // namespace modtap
