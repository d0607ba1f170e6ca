#include "tools/modtap/model_catalog.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "decoder/models/model_yaml.hpp"
#include "decoder/protocol/nearest_name.hpp"
#include "plugins/models/builtin_models.hpp"

namespace modtap::tools {

namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot open", path));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

void ModelCatalog::load_builtin() {
  std::vector<ModelFile> files;
  for (const auto& builtin : models::builtin_models())
    files.emplace_back(builtin.yaml, std::string(builtin.file));
  load(std::move(files), "built-in");
}

void ModelCatalog::load_dir(const std::string& dir) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(dir)) throw std::runtime_error(fmt::format("{}: not a directory", dir));
  std::vector<std::string> paths;
  for (const auto& item : fs::directory_iterator(dir))
    if (item.path().extension() == ".yaml" || item.path().extension() == ".yml")
      paths.push_back(item.path().string());
  std::sort(paths.begin(), paths.end());
  std::vector<ModelFile> files;
  for (const auto& path : paths) {
    try {
      files.emplace_back(read_text(path), path);
    } catch (const ModelError& e) {
      left_out_.insert(left_out_.end(), e.problems().begin(), e.problems().end());
    } catch (const std::runtime_error& e) {
      left_out_.emplace_back(e.what());
    }
  }
  load(std::move(files), dir);
}

// Models that extend another load after it, so bases are loaded in passes until none is left.
// A problem in a built-in model is an error; a user's file with one is left out, and said.
void ModelCatalog::load(std::vector<ModelFile> files, const std::string& origin) {
  const bool builtin = origin == "built-in";
  std::vector<std::string> problems;
  while (!files.empty()) {
    std::vector<ModelFile> waiting;
    for (auto& file : files) {
      const DeviceModel* base = file.base().empty() ? nullptr : find(file.base());
      if (!file.base().empty() && !base) {
        waiting.push_back(std::move(file));
        continue;
      }
      try {
        add(file.model(base), builtin ? origin : file.file());
      } catch (const ModelError& e) {
        problems.insert(problems.end(), e.problems().begin(), e.problems().end());
      }
    }
    if (waiting.size() == files.size()) {
      for (const auto& file : waiting)
        problems.push_back(
            fmt::format("{}: extends '{}', which is not a known model", file.file(), file.base()));
      break;
    }
    files = std::move(waiting);
  }
  if (builtin && !problems.empty()) throw ModelError(problems);
  left_out_.insert(left_out_.end(), problems.begin(), problems.end());
}

void ModelCatalog::add(DeviceModel model, std::string origin) {
  for (auto& entry : entries_) {
    if (entry.model.name != model.name) continue;
    entry = {std::move(model), std::move(origin)};  // a user's file replaces a built-in
    return;
  }
  entries_.push_back({std::move(model), std::move(origin)});
}

const DeviceModel* ModelCatalog::find(std::string_view name) const {
  for (const auto& entry : entries_)
    if (entry.model.name == name) return &entry.model;
  return nullptr;
}

std::vector<const DeviceModel*> ModelCatalog::all() const {
  std::vector<const DeviceModel*> models;
  for (const auto& entry : entries_) models.push_back(&entry.model);
  return models;
}

ModelChoice ModelCatalog::choose(const std::vector<std::string>& specs) const {
  ModelChoice choice;
  auto model_named = [&](const std::string& name) {
    const DeviceModel* model = find(name);
    if (model) return model;
    NearestName nearest(name);
    for (const auto& entry : entries()) nearest.consider(entry.model.name);
    throw std::runtime_error(fmt::format("no model named '{}'{} (modtap models lists them)", name,
                                         nearest.suggestion()));
  };
  for (const auto& spec : specs) {
    const auto eq = spec.find('=');
    if (eq == std::string::npos) {
      choice.bus = model_named(spec);
      continue;
    }
    unsigned slave = 0;
    const std::string number = spec.substr(0, eq);
    if (number.empty() || number.find_first_not_of("0123456789") != std::string::npos ||
        (slave = static_cast<unsigned>(std::stoul(number))) > 255)
      throw std::runtime_error(fmt::format("--model {}: expected SLAVE=MODEL, SLAVE 1-255", spec));
    if (slave == 0)
      throw std::runtime_error(fmt::format(
          "--model {}: slave 0 is the broadcast address, which no device answers as: give the "
          "device's own address",
          spec));
    choice.by_slave[static_cast<uint8_t>(slave)] = model_named(spec.substr(eq + 1));
  }
  if (!choice.bus) choice.bus = find("generic");
  return choice;
}

int check_model_files(const std::vector<std::string>& files, const std::string& models_dir) {
  ModelCatalog catalog;
  catalog.load_builtin();
  if (!models_dir.empty()) catalog.load_dir(models_dir);
  int status = 0;
  for (const auto& file : files) status |= check_model_file(catalog, file);
  return status;
}

int check_model_file(const ModelCatalog& catalog, const std::string& file) {
  try {
    const ModelFile parsed(read_text(file), file);
    const DeviceModel* base = parsed.base().empty() ? nullptr : catalog.find(parsed.base());
    if (!parsed.base().empty() && !base)
      throw ModelError(
          {fmt::format("{}: extends '{}', which is no built-in model nor one of "
                       "--models-dir",
                       file, parsed.base())});
    const DeviceModel model = parsed.model(base);
    fmt::print("{}: model {} ({}{}{}): {} registers, {} exception codes{}\n", file, model.name,
               model.title, model.source.empty() ? "" : ", from ", model.source,
               model.registers.size(), model.exceptions.size(),
               model.groups ? ", parameter groups by rule" : "");
    return 0;
  } catch (const ModelError& e) {
    for (const auto& problem : e.problems()) fmt::print(stderr, "{}\n", problem);
    return 1;
  } catch (const std::runtime_error& e) {  // unreadable: said, and the next file checked
    fmt::print(stderr, "{}\n", e.what());
    return 1;
  }
}

}  // namespace modtap::tools
