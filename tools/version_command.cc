// `mcvo version`: prints the version and the versions of the libraries the
// binary was built against (useful in batch logs and bug reports).
#include <ceres/version.h>
#include <Eigen/Core>
#include <iostream>
#include <opencv2/core/version.hpp>

#include "command.h"
#include "mcvo/util/args.h"
#include "mcvo/util/blas.h"

namespace mcvo::tools {
namespace {

int RunVersion(int argc, const char* const* argv) {
  ArgParser args("mcvo version", "Prints the mcvo version and the library versions it was built with.");
  if (!args.Parse(argc, argv)) return 0;
  std::cout << "mcvo " << MCVO_VERSION << "\n"
            << "eigen " << EIGEN_WORLD_VERSION << "." << EIGEN_MAJOR_VERSION << "." << EIGEN_MINOR_VERSION
            << "\n"
            << "ceres " << CERES_VERSION_STRING << "\n"
            << "opencv " << CV_VERSION << "\n"
            << "blas " << (BlasLibrary().empty() ? "(none loaded)" : BlasLibrary()) << "\n";
  return 0;
}

const CommandRegistrar kRegistrar("version", {"print version information", RunVersion});

}  // namespace
}  // namespace mcvo::tools
