// `polysft --config`: a settings file (ApplyPolySftSettingsFile), JSON
// with one key per setting, or an earlier run's metrics.json.
#include "sft/solver/polysft_settings.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = polyfit::fuzz::Scratch::Get().Write("config.json", data, size);
  polyfit::fuzz::ExpectCleanRejection(
      [&] {
        polyfit::PolySftOptions options;
        polyfit::ApplyPolySftSettingsFile(path, &options);
      },
      "config.json");
  return 0;
}
