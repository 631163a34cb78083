#include "mcvo/util/error.h"

#include <cstdio>
#include <cstdlib>

namespace mcvo::internal {

void CheckFailed(const char* file, int line, const char* expr, const std::string& message) {
  std::fprintf(stderr, "mcvo: internal error: %s:%d: check failed: %s%s%s\n", file, line, expr,
               message.empty() ? "" : ": ", message.c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace mcvo::internal
