// Cancellation by SIGINT (Ctrl-C) and SIGTERM (kill, a batch scheduler's
// time limit): the first signal asks the command to stop at its next safe
// point, where ThrowIfCancelled() throws Cancelled; the exception unwinds
// through the staging folders (util/output_folder.h), which remove what they
// hold, and the executable exits 128 + the signal number (130, 143). A second
// signal ends the process at once (the default action): a staging folder
// left by that is removed by the next command on the same output.
#pragma once

#include <stdexcept>

namespace mcvo {

class Cancelled : public std::runtime_error {
 public:
  explicit Cancelled(int signal_number);
  int signal_number() const { return signal_number_; }

 private:
  int signal_number_;
};

// Installs the handlers of SIGINT and SIGTERM (once per process; the
// executable's main calls it).
void InstallCancelHandlers();

// The signal that asked to stop, or 0.
int CancelSignal();

// Throws Cancelled when a signal asked to stop.
void ThrowIfCancelled();

// As if `signal_number` had arrived (0 clears the request): for an embedder
// that handles signals itself (the Python module on KeyboardInterrupt) and
// for tests.
void RequestCancel(int signal_number);

}  // namespace mcvo
