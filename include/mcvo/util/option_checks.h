// Checks of option values for the options structs' Check() methods. Each
// throws InputError "<json path>: must be ..., got ..." so a bad config
// value is reported at its place in the config file.
#pragma once

#include <string>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {

inline std::string OptionText(double value) { return FormatDouble(value); }
inline std::string OptionText(int value) { return std::to_string(value); }

template <typename T>
void CheckAtLeast(const char* path, T value, T min) {
  if (!(value >= min)) MCVO_THROW_INPUT(path, ": must be >= ", OptionText(min), ", got ", OptionText(value));
}

template <typename T>
void CheckPositive(const char* path, T value) {
  if (!(value > T(0))) MCVO_THROW_INPUT(path, ": must be > 0, got ", OptionText(value));
}

inline void CheckInRange(const char* path, double value, double min, double max) {
  if (!(value >= min && value <= max)) {
    MCVO_THROW_INPUT(path, ": must be in [", OptionText(min), ", ", OptionText(max), "], got ",
                     OptionText(value));
  }
}

}  // namespace mcvo
