// The device model loader on any text, alone and extending a built-in model. Properties: a
// model or a ModelError whose problems name the file; never a crash, whatever yaml-cpp is fed.
#include <string>
#include <string_view>

#include "decoder/model_yaml.hpp"
#include "tests/fuzz/fuzz_input.hpp"
#include "tools/modtap/model_catalog.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace modtap;
  static const tools::ModelCatalog catalog = [] {
    tools::ModelCatalog c;
    c.load_builtin();
    return c;
  }();
  const std::string_view yaml(reinterpret_cast<const char*>(data), size);
  for (const decoder::DeviceModel* base :
       {static_cast<const decoder::DeviceModel*>(nullptr), catalog.find("nta5000")}) {
    try {
      const decoder::DeviceModel model = decoder::parse_model(yaml, "fuzz.yaml", base);
      FUZZ_EXPECT(!model.name.empty());
    } catch (const decoder::ModelError& e) {
      FUZZ_EXPECT(!e.problems().empty());
      for (const auto& problem : e.problems()) FUZZ_EXPECT(problem.rfind("fuzz.yaml", 0) == 0);
    }
  }
  return 0;
}
