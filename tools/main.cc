// `mcvo`: one executable, one subcommand per job. Exit codes: 0 ok,
// 1 internal error, 2 usage, 3 bad input (mcvo/util/error.h).
#include <clocale>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "command.h"
#include "mcvo/util/blas.h"
#include "mcvo/util/cancel.h"
#include "mcvo/util/error.h"
#include "mcvo/util/stage.h"

namespace mcvo::tools {

std::map<std::string, CommandInfo>& CommandRegistry() {
  static std::map<std::string, CommandInfo> registry;
  return registry;
}

namespace {

void PrintTopLevelHelp(std::ostream& out) {
  out << "usage: mcvo <command> [options]\n\n"
         "mcvo: offline multi-camera visual odometry and reconstruction.\n\ncommands:\n";
  for (const auto& [name, info] : CommandRegistry()) {
    std::string left = "  " + name;
    left.resize(std::max<size_t>(left.size() + 2, 14), ' ');
    out << left << info.summary << "\n";
  }
  out << "\n'mcvo <command> --help' describes a command.\n"
         "exit codes: 0 ok, 1 internal error (or out of memory, or out of threads), 2 usage error,\n"
         "3 bad input.\n";
}

}  // namespace
}  // namespace mcvo::tools

int main(int argc, char** argv) {
  using namespace mcvo;
  std::setlocale(LC_ALL, "C");
  PinBlasToOneThread();
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0 ||
      std::strcmp(argv[1], "help") == 0) {
    tools::PrintTopLevelHelp(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? kExitUsage : kExitOk;
  }
  if (std::strcmp(argv[1], "--version") == 0) {
    std::cout << "mcvo " << MCVO_VERSION << "\n";
    return kExitOk;
  }
  const auto it = tools::CommandRegistry().find(argv[1]);
  if (it == tools::CommandRegistry().end()) {
    std::cerr << "mcvo: unknown command '" << argv[1] << "' (see mcvo --help)\n";
    return kExitUsage;
  }
  InstallCancelHandlers();
  try {
    return it->second.run(argc - 2, argv + 2);
  } catch (const Cancelled& e) {
    std::cerr << "mcvo " << argv[1] << ": " << e.what() << "\n";
    return 128 + e.signal_number();
  } catch (const UsageError& e) {
    std::cerr << "mcvo " << argv[1] << ": usage error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const InputError& e) {
    std::cerr << "mcvo " << argv[1] << ": error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const ResourceError& e) {
    std::cerr << "mcvo " << argv[1] << ": error: " << e.what() << "\n";
    return kExitInternal;
  } catch (const std::bad_alloc& e) {
    std::cerr << OutOfMemoryMessage(argv[1], FailedStage(), e.what()) << "\n";
    return kExitInternal;
  } catch (const std::length_error& e) {  // a size beyond what a container can hold
    std::cerr << OutOfMemoryMessage(argv[1], FailedStage(), e.what()) << "\n";
    return kExitInternal;
  } catch (const cv::Exception& e) {
    if (e.code == cv::Error::StsNoMem) {
      std::cerr << OutOfMemoryMessage(argv[1], FailedStage(), "OpenCV: " + e.err) << "\n";
    } else {
      std::cerr << "mcvo " << argv[1] << ": internal error: " << e.what() << "\n";
    }
    return kExitInternal;
  } catch (const std::exception& e) {
    if (const int signal_number = CancelSignal(); signal_number != 0) {
      // An error on the way out of a cancelled command (a read interrupted by the signal).
      std::cerr << "mcvo " << argv[1] << ": " << Cancelled(signal_number).what() << "\n";
      return 128 + signal_number;
    }
    std::cerr << "mcvo " << argv[1] << ": internal error: " << e.what() << "\n";
    return kExitInternal;
  }
}
