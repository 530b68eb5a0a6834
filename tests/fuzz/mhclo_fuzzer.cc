// ReadMhclo: a MakeHuman garment's binding to the body.
#include "drape/garment/mhclo_garment.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = polyfit::fuzz::Scratch::Get().Write("garment.mhclo", data, size);
  polyfit::fuzz::ExpectCleanRejection([&] { polyfit::ReadMhclo(path); }, "garment.mhclo");
  return 0;
}
