// The extension module mcvo._mcvo (docs/python.md); python/mcvo/__init__.py
// re-exports it with the parts written in Python.
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <exception>
#include <mutex>
#include <string>
#include <thread>

#include <pybind11/stl.h>

#include "bindings.h"
#include "mcvo/util/blas.h"
#include "mcvo/util/cancel.h"
#include "mcvo/util/error.h"
#include "mcvo/util/logging.h"

namespace mcvo::python {

std::string PathString(const py::handle& path) {
  return py::str(py::module_::import("os").attr("fspath")(path)).cast<std::string>();
}

void RunInterruptible(const std::function<void()>& work, const std::function<void()>& poll) {
  std::mutex mutex;
  std::condition_variable finished_cv;
  bool finished = false;
  std::exception_ptr work_error;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      work_error = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex);
    finished = true;
    finished_cv.notify_all();
  });
  // The exception that stopped the work (KeyboardInterrupt, or one the poll
  // raised); the work is asked to stop once and waited for.
  std::exception_ptr stop_error;
  for (;;) {
    bool done = false;
    {
      py::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(mutex);
      done = finished_cv.wait_for(lock, std::chrono::milliseconds(50), [&] { return finished; });
    }
    if (done) break;
    if (stop_error) continue;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (poll) poll();
    } catch (...) {
      stop_error = std::current_exception();
      RequestCancel(SIGINT);
    }
  }
  worker.join();
  if (stop_error) {
    RequestCancel(0);
    std::rethrow_exception(stop_error);
  }
  if (work_error) std::rethrow_exception(work_error);
}

namespace {

void SetLogLevelByName(const std::string& name) {
  if (name == "debug") {
    SetLogLevel(LogLevel::kDebug);
  } else if (name == "info") {
    SetLogLevel(LogLevel::kInfo);
  } else if (name == "warning") {
    SetLogLevel(LogLevel::kWarning);
  } else if (name == "error") {
    SetLogLevel(LogLevel::kError);
  } else if (name == "quiet") {
    SetLogLevel(LogLevel::kQuiet);
  } else {
    throw UsageError("log level: expected debug, info, warning, error or quiet, got '" + name + "'");
  }
}

}  // namespace
}  // namespace mcvo::python

PYBIND11_MODULE(_mcvo, m) {
  namespace py = pybind11;
  using namespace mcvo::python;
  m.doc() = "mcvo: offline multi-camera visual odometry (docs/python.md)";
  // As the executable's main: a threaded OpenBLAS stays on one thread (mcvo/util/blas.h).
  mcvo::PinBlasToOneThread();
  m.attr("__version__") = MCVO_VERSION;

  static py::exception<mcvo::InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<mcvo::UsageError> usage_error(m, "UsageError", PyExc_ValueError);
  input_error.doc() = "Bad input: a file or value; the message names the file and the line or JSON path.";
  usage_error.doc() = "Bad use of a function: an unknown option value or a bad argument.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const mcvo::InputError& e) {
      PyErr_SetString(input_error.ptr(), e.what());
    } catch (const mcvo::UsageError& e) {
      PyErr_SetString(usage_error.ptr(), e.what());
    } catch (const mcvo::Cancelled& e) {
      PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
    }
  });

  m.def("set_log_level", &SetLogLevelByName, py::arg("level"),
        "Log lines on stderr from this level up: debug, info (default), warning, error or quiet.");
  m.def(
      "log_level",
      [] {
        static const char* const kNames[] = {"debug", "info", "warning", "error", "quiet"};
        return std::string(kNames[static_cast<int>(mcvo::GetLogLevel())]);
      },
      "The current log level.");

  BindCamera(m);
  BindDataset(m);
  BindTrajectory(m);
  BindRun(m);
  BindSynth(m);
}
