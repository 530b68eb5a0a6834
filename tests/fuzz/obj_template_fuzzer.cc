// ReadObjTemplate: PolyFit's own OBJ reader, vertices in file order.
#include "polyfit/mesh/ordered_io.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = polyfit::fuzz::Scratch::Get().Write("template.obj", data, size);
  polyfit::fuzz::ExpectCleanRejection([&] { polyfit::ReadObjTemplate(path); }, "template.obj");
  return 0;
}
