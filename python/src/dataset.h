// mcvo.Dataset: what open_dataset read and the options it read it with, so
// that mcvo.run opens the same dataset the same way.
#pragma once

#include <string>

#include <pybind11/pybind11.h>

#include "mcvo/dataset/dataset.h"

namespace mcvo::python {

struct PyDataset {
  DatasetOptions options;
  DatasetIndex index;
};

// DatasetOptions as the command line's dataset flags make them
// (tools/dataset_args.cc): cameras None, a list of names or "a,b".
DatasetOptions MakeDatasetOptions(const pybind11::object& root, const std::string& format,
                                  const pybind11::object& cameras, const std::string& sequence,
                                  bool skip_incomplete);
PyDataset OpenPyDataset(const DatasetOptions& options);

}  // namespace mcvo::python
