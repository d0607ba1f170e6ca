// The device model loader on any text, alone and extending a built-in model. Properties: a
// model or a ModelError whose problems name the file; never a crash, whatever libyaml is fed.
#include <string>
#include <string_view>

#include "decoder/models/model_yaml.hpp"
#include "tests/fuzz/fuzz_input.hpp"
#include "tools/modtap/model_catalog.hpp"

namespace {

void expect_names_the_file(const modtap::ModelError& e) {
  FUZZ_EXPECT(!e.problems().empty());
  for (const auto& problem : e.problems()) FUZZ_EXPECT(problem.rfind("fuzz.yaml", 0) == 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  static const tools::ModelCatalog catalog = [] {
    tools::ModelCatalog c;
    c.load_builtin();
    return c;
  }();
  const std::string_view yaml(reinterpret_cast<const char*>(data), size);
  // The text is parsed once and read as a model twice: alone and extending a built-in one.
  try {
    const ModelFile file(yaml, "fuzz.yaml");
    for (const DeviceModel* base :
         {static_cast<const DeviceModel*>(nullptr), catalog.find("nta5000")}) {
      try {
        FUZZ_EXPECT(!file.model(base).name.empty());
      } catch (const ModelError& e) {
        expect_names_the_file(e);
      }
    }
  } catch (const ModelError& e) {
    expect_names_the_file(e);
  }
  return 0;
}
