// mcvo.open_dataset and mcvo.Dataset: a dataset's metadata as OpenDataset
// reads it (dataset/dataset.h), the way `mcvo run` opens it.
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "bindings.h"
#include "dataset.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::python {

DatasetOptions MakeDatasetOptions(const py::object& root, const std::string& format, const py::object& cameras,
                                  const std::string& sequence, bool skip_incomplete) {
  DatasetOptions options;
  options.root = PathString(root);
  options.format = format;
  options.sequence = sequence;
  if (!cameras.is_none()) {
    if (py::isinstance<py::str>(cameras)) {
      // "a,b" as on the command line (tools/dataset_args.cc).
      const std::string text = cameras.cast<std::string>();
      for (const std::string_view field : SplitFields(text, ',')) options.cameras.emplace_back(field);
    } else {
      options.cameras = cameras.cast<std::vector<std::string>>();
    }
  }
  options.missing_images = skip_incomplete ? MissingImagePolicy::kSkipFrame : MissingImagePolicy::kMarkMissing;
  options.Check();
  return options;
}

PyDataset OpenPyDataset(const DatasetOptions& options) {
  PyDataset dataset;
  dataset.options = options;
  {
    py::gil_scoped_release release;
    dataset.index = OpenDataset(options);
  }
  return dataset;
}

namespace {

py::array_t<int64_t> FrameTimes(const PyDataset& d) {
  py::array_t<int64_t> times(static_cast<py::ssize_t>(d.index.frames.size()));
  int64_t* out = times.mutable_data();
  for (size_t i = 0; i < d.index.frames.size(); ++i) out[i] = d.index.frames[i].t_ns;
  return times;
}

py::object ImagePaths(const PyDataset& d) {
  py::list rows;
  for (const DatasetFrame& frame : d.index.frames) {
    py::list row;
    for (const std::filesystem::path& image : frame.images) row.append(py::str(image.string()));
    rows.append(row);
  }
  py::module_ np = py::module_::import("numpy");
  if (d.index.frames.empty()) {
    return np.attr("empty")(py::make_tuple(0, d.index.rig.NumCameras()), py::arg("dtype") = "str");
  }
  return np.attr("array")(rows, py::arg("dtype") = "str");
}

}  // namespace

void BindDataset(py::module_& m) {
  py::class_<PyDataset>(m, "Dataset",
                        "A dataset's metadata (no image decoded): rig, frames, ground truth (docs/datasets.md).")
      .def_property_readonly("root", [](const PyDataset& d) { return d.index.root.string(); })
      .def_property_readonly("format", [](const PyDataset& d) { return d.index.format; },
                             "the layout that was read: generic, kitti360, kitti, euroc or kalibr")
      .def_property_readonly("name", [](const PyDataset& d) { return d.index.name; })
      .def_property_readonly("sequence", [](const PyDataset& d) { return d.options.sequence; })
      .def_property_readonly("rig", [](const PyDataset& d) { return d.index.rig; })
      .def_property_readonly("camera_names",
                             [](const PyDataset& d) {
                               std::vector<std::string> names;
                               for (const Camera& c : d.index.rig.cameras) names.push_back(c.name);
                               return names;
                             })
      .def_property_readonly("times", &FrameTimes, "frame times, int64 nanoseconds (N)")
      .def_property_readonly(
          "times_s",
          [](const PyDataset& d) {
            py::array_t<double> times(static_cast<py::ssize_t>(d.index.frames.size()));
            for (size_t i = 0; i < d.index.frames.size(); ++i) {
              times.mutable_data()[i] = static_cast<double>(d.index.frames[i].t_ns) * 1e-9;
            }
            return times;
          },
          "frame times in seconds, float64 (N)")
      .def_property_readonly("image_paths", &ImagePaths,
                             "N x cameras array of image paths (str; '' where an image is missing)")
      .def_property_readonly(
          "ground_truth",
          [](const PyDataset& d) -> py::object {
            if (!d.index.ground_truth) return py::none();
            return TrajectoryToArray(*d.index.ground_truth);
          },
          "world_from_rig as N x 8 float64 in TUM order (t tx ty tz qx qy qz qw), or None")
      .def_property_readonly("log", [](const PyDataset& d) { return d.index.log; },
                             "what the reader did (synchronisation, generated masks)")
      .def("__len__", [](const PyDataset& d) { return d.index.frames.size(); })
      .def("__repr__", [](const PyDataset& d) {
        return StrCat("<mcvo.Dataset '", d.index.name, "' (", d.index.format, "): ", d.index.frames.size(),
                      " frames, ", d.index.rig.NumCameras(), " cameras>");
      });

  m.def(
      "open_dataset",
      [](const py::object& path, const std::string& format, const py::object& cameras, const std::string& sequence,
         bool skip_incomplete) {
        return OpenPyDataset(MakeDatasetOptions(path, format, cameras, sequence, skip_incomplete));
      },
      py::arg("path"), py::arg("format") = "auto", py::arg("cameras") = py::none(), py::arg("sequence") = "",
      py::arg("skip_incomplete") = false,
      "Opens a dataset folder (any layout: auto, generic, kitti360, kitti, euroc, kalibr). cameras: names (a "
      "list, or 'a,b'), the subset and order of the rig; default all. Bad input raises InputError.");
}

}  // namespace mcvo::python
