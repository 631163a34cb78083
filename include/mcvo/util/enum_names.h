// Names of enum values as used in config files and on the command line.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

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

template <typename Enum, size_t N>
std::optional<Enum> EnumFromName(const EnumName<Enum> (&table)[N], std::string_view name) {
  for (const EnumName<Enum>& entry : table) {
    if (name == entry.name) return entry.value;
  }
  return std::nullopt;
}

// "a, b, c": the names of the table, for error messages.
template <typename Enum, size_t N>
std::string EnumNameList(const EnumName<Enum> (&table)[N]) {
  std::string list;
  for (const EnumName<Enum>& entry : table) list += (list.empty() ? "" : ", ") + std::string(entry.name);
  return list;
}

}  // namespace mcvo
