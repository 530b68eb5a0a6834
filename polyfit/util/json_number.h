// A double as JSON: NaN and infinities (metrics that do not apply, such as
// an error without ground truth) become null, which JSON can hold.
#ifndef POLYFIT_UTIL_JSON_NUMBER_H_
#define POLYFIT_UTIL_JSON_NUMBER_H_

#include <cmath>

#include <nlohmann/json.hpp>

namespace polyfit {

inline nlohmann::json JsonNumber(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

}  // namespace polyfit

#endif  // POLYFIT_UTIL_JSON_NUMBER_H_
