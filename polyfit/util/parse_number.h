// Whole-token number parsing for the text formats we read (OFF, PLY).
#ifndef POLYFIT_UTIL_PARSE_NUMBER_H_
#define POLYFIT_UTIL_PARSE_NUMBER_H_

#include <charconv>
#include <string_view>
#include <system_error>

namespace polyfit {

// True when all of `token` is one decimal number (a leading '+' allowed,
// as strtod allows; "nan" and "inf" parse, so callers check finiteness).
// Locale-independent and without allocation, unlike strtod on a copy.
inline bool ParseNumber(std::string_view token, double* value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return error == std::errc() && end == token.data() + token.size();
}

}  // namespace polyfit

#endif  // POLYFIT_UTIL_PARSE_NUMBER_H_
