// Names of enum values as used in config files and on the command line.
#pragma once

#include <cstddef>

namespace mcvo {

// An enum value and its name in the config file.
template <typename Enum>
struct EnumName {
  Enum value;
  const char* name;
};

template <typename Enum, size_t N>
constexpr const char* EnumToName(const EnumName<Enum> (&table)[N], Enum value) {
  for (const EnumName<Enum>& entry : table) {
    if (entry.value == value) return entry.name;
  }
  return "?";
}

}  // namespace mcvo
