// The pieces of the Python module `mcvo` (docs/python.md), one file per
// area: cameras and rigs, datasets, trajectories and evaluation, the
// pipeline and the renderer. module.cc puts them together.
#pragma once

#include <functional>
#include <string>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "mcvo/io/trajectory_io.h"

namespace mcvo::python {

namespace py = pybind11;

void BindCamera(py::module_& m);
void BindDataset(py::module_& m);
void BindTrajectory(py::module_& m);
void BindRun(py::module_& m);
void BindSynth(py::module_& m);

// A trajectory as an N x 8 float64 array in TUM order (t tx ty tz qx qy qz
// qw, t in seconds; NaN for a trajectory without time stamps).
py::array_t<double> TrajectoryToArray(const Trajectory& trajectory);
// The inverse: times from column 0 when every one is finite (rounded to
// whole nanoseconds), else none and frame_index = the row.
Trajectory ArrayToTrajectory(const py::array_t<double, py::array::c_style | py::array::forcecast>& array,
                             const std::string& what);

// A str or os.PathLike as a path string (os.fspath).
std::string PathString(const py::handle& path);

// Runs `work` on a worker thread while the calling thread, which holds the
// GIL, waits without it: every 50 ms it takes the GIL back, checks for
// signals (Ctrl-C: KeyboardInterrupt) and calls `poll` (may be empty; a
// Python exception it raises stops the work the same way). On either, the
// work is cancelled at its next safe point (mcvo::RequestCancel; nothing is
// left behind), the worker is joined, the request cleared and the Python
// exception raised. Otherwise the worker's exception, if any, is rethrown.
void RunInterruptible(const std::function<void()>& work, const std::function<void()>& poll);

}  // namespace mcvo::python
