// LoadOneFitModel: the network's model file (docs/onefit-model-format.md).
#include "drape/network/onefit_model.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = polyfit::fuzz::Scratch::Get().Write("model.pfonefit", data, size);
  polyfit::fuzz::ExpectCleanRejection([&] { polyfit::LoadOneFitModel(path); }, "model.pfonefit");
  return 0;
}
