// mcvo/util/blas.h
#include "mcvo/util/blas.h"

#include <dlfcn.h>

#include <climits>
#include <cstdlib>

namespace mcvo {

void PinBlasToOneThread() {
  using SetThreads = void (*)(int);
  void* symbol = dlsym(RTLD_DEFAULT, "openblas_set_num_threads");
  if (symbol != nullptr) reinterpret_cast<SetThreads>(symbol)(1);
}

std::string BlasLibrary() {
  void* symbol = dlsym(RTLD_DEFAULT, "dgemm_");
  if (symbol == nullptr) return "";
  Dl_info info{};
  if (dladdr(symbol, &info) == 0 || info.dli_fname == nullptr) return "";
  char resolved[PATH_MAX];
  if (realpath(info.dli_fname, resolved) == nullptr) return info.dli_fname;
  return resolved;
}

}  // namespace mcvo
