// Minimal leveled logging to stderr. Log lines never go into output files, so
// they may carry timings without breaking byte-identical outputs.
#pragma once

#include <string>

#include "mcvo/util/error.h"

namespace mcvo {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3, kQuiet = 4 };

void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();
void LogMessage(LogLevel level, const std::string& message);

}  // namespace mcvo

#define MCVO_LOG(level, ...)                                                    \
  do {                                                                          \
    if (::mcvo::LogLevel::level >= ::mcvo::GetLogLevel())                       \
      ::mcvo::LogMessage(::mcvo::LogLevel::level, ::mcvo::StrCat(__VA_ARGS__)); \
  } while (false)
