// The device models modtap knows: the built-in ones and the user's files (--models-dir).
#pragma once

#include <deque>
#include <string>
#include <string_view>
#include <vector>

#include "decoder/models/device_model.hpp"
#include "decoder/models/model_interpreter.hpp"
#include "decoder/models/model_yaml.hpp"

namespace modtap::tools {

class ModelCatalog {
 public:
  struct Entry {
    DeviceModel model;
    std::string origin;  // "built-in" or the file it came from
  };

  // Throws ModelError naming the file and line of each problem.
  void load_builtin();
  // Every *.yaml in it; a name may replace a built-in. A file with a problem is left out.
  void load_dir(const std::string& dir);
  // The problems of the files load_dir left out, each naming the file (and line).
  const std::vector<std::string>& left_out() const { return left_out_; }

  const DeviceModel* find(std::string_view name) const;
  const std::deque<Entry>& entries() const { return entries_; }
  std::vector<const DeviceModel*> all() const;

  // From --model values: "MODEL" for the bus, "SLAVE=MODEL" for one slave. No model: generic.
  ModelChoice choose(const std::vector<std::string>& specs) const;

 private:
  void load(std::vector<ModelFile> files, const std::string& origin);
  void add(DeviceModel model, std::string origin);

  std::deque<Entry> entries_;  // a deque: ModelChoice holds pointers into it
  std::vector<std::string> left_out_;
};

// `modtap models check FILE...`: loads each file against the built-in models and those of
// `models_dir` (a file may extend a user's model) and prints what it finds: the model, or every
// problem with its line, or that it cannot be read, and goes on. Returns the process status, 1
// if any file has a problem.
int check_model_files(const std::vector<std::string>& files, const std::string& models_dir);
int check_model_file(const ModelCatalog& catalog, const std::string& file);

}  // namespace modtap::tools
