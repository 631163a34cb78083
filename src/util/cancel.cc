#include "mcvo/util/cancel.h"

#include <csignal>
#include <cstring>
#include <string>

namespace mcvo {
namespace {

volatile std::sig_atomic_t g_signal = 0;

extern "C" void OnCancelSignal(int signal_number) {
  g_signal = signal_number;
  // The next signal of either kind ends the process (the default action).
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
}

std::string SignalText(int signal_number) {
  switch (signal_number) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    default:
      return "signal " + std::to_string(signal_number);
  }
}

}  // namespace

Cancelled::Cancelled(int signal_number)
    : std::runtime_error("cancelled by " + SignalText(signal_number) + ": nothing was written"),
      signal_number_(signal_number) {}

void InstallCancelHandlers() {
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = OnCancelSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // reads and writes go on; the command stops at its next check
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

int CancelSignal() { return static_cast<int>(g_signal); }

void ThrowIfCancelled() {
  const int signal_number = CancelSignal();
  if (signal_number != 0) throw Cancelled(signal_number);
}

void RequestCancel(int signal_number) { g_signal = signal_number; }

}  // namespace mcvo
