// PolySftOptions as JSON: the "settings" of metrics.json and the file that
// `polysft --config` reads are the same object, so a run's settings fed
// back reproduce it. Every key is listed once (polysft_settings.cc) and
// serves both directions.
#ifndef POLYFIT_SFT_SOLVER_POLYSFT_SETTINGS_H_
#define POLYFIT_SFT_SOLVER_POLYSFT_SETTINGS_H_

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sft/solver/polysft.h"

namespace polyfit {

// Every setting, as an object with one key per setting.
nlohmann::json PolySftSettingsToJson(const PolySftOptions& options);

// Sets the keys present in `settings` (an object), leaving the others.
// Throws Error (kInvalidArgument) naming `source` and the key for an
// unknown key or a value of the wrong type or out of its set.
void ApplyPolySftSettings(const nlohmann::json& settings, const std::string& source, PolySftOptions* options);

// Reads a JSON file of settings (ApplyPolySftSettings), or a metrics.json
// of an earlier run (its "settings"); Error (kInput) naming the file when
// it cannot be read or parsed.
void ApplyPolySftSettingsFile(const std::string& path, PolySftOptions* options);

// The keys, in the order they are written.
std::vector<std::string> PolySftSettingKeys();

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_POLYSFT_SETTINGS_H_
