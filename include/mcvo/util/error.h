// Error handling conventions (docs/ARCHITECTURE.md, "Errors").
//
//  * Broken internal invariant        -> MCVO_CHECK: prints file:line and aborts.
//  * Bad input (file, calibration...) -> throw InputError naming the file and the
//                                        line or JSON path; tools/ exits with 3.
//  * Bad command-line use             -> throw UsageError; tools/ exits with 2.
//  * The system refuses a resource    -> throw ResourceError (one line, saying
//    (a thread: ulimit -u)               which limit and what to try); exit 1.
//  * Expected algorithmic failure     -> std::optional / status, never an exception.
//
// The library never calls std::exit.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace mcvo {

// Process exit codes of the mcvo executable.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,
  kExitUsage = 2,
  kExitBadInput = 3,
  // 4: used by batch and regress (some run failed / runs differ).
  // `mcvo run` wrote its outputs but posed no frame (run.json "warning" says why).
  kExitNothingPosed = 5,
};

// A user-supplied file or value is invalid. what() is one line of the form
// "<file>[:<line> | <json path>]: <what is wrong>".
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The command line is invalid (unknown flag, missing argument).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The system refused a resource the run needs (a thread: the process or user
// thread limit). what() is one line saying what was refused and what to try.
class ResourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace internal {
[[noreturn]] void CheckFailed(const char* file, int line, const char* expr, const std::string& message);

template <typename... Args>
std::string StrCat(const Args&... args) {
  std::ostringstream out;
  (out << ... << args);
  return out.str();
}
}  // namespace internal

// Concatenates the streamable arguments into a string.
template <typename... Args>
std::string StrCat(const Args&... args) {
  return internal::StrCat(args...);
}

}  // namespace mcvo

// Aborts with file:line when an internal invariant does not hold.
#define MCVO_CHECK(cond)                                                       \
  do {                                                                         \
    if (!(cond)) ::mcvo::internal::CheckFailed(__FILE__, __LINE__, #cond, ""); \
  } while (false)

// As MCVO_CHECK, with the streamed arguments appended to the message.
#define MCVO_CHECK_MSG(cond, ...)                                                                       \
  do {                                                                                                  \
    if (!(cond)) ::mcvo::internal::CheckFailed(__FILE__, __LINE__, #cond, ::mcvo::StrCat(__VA_ARGS__)); \
  } while (false)

// Throws InputError with the streamed message.
#define MCVO_THROW_INPUT(...) throw ::mcvo::InputError(::mcvo::StrCat(__VA_ARGS__))
