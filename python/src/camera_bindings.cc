// mcvo.Camera and mcvo.Rig: rig.json, the camera models, projection of
// many points at once (camera/camera.h, io/rig_io.h).
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.h"
#include "mcvo/camera/camera.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/util/error.h"

namespace mcvo::python {
namespace {

using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The rows of an N x `dims` array (or one point of `dims` values), checked.
const double* PointRows(const InArray& array, int dims, const char* what, py::ssize_t* rows, bool* single) {
  *single = array.ndim() == 1;
  if (!((array.ndim() == 2 && array.shape(1) == dims) || (array.ndim() == 1 && array.shape(0) == dims))) {
    throw UsageError(StrCat(what, ": expected an N x ", dims, " array (or ", dims, " values), got shape (",
                            array.ndim() >= 1 ? std::to_string(array.shape(0)) : std::string(),
                            array.ndim() >= 2 ? ", " + std::to_string(array.shape(1)) : std::string(), ")"));
  }
  *rows = *single ? 1 : array.shape(0);
  return array.data();
}

py::array_t<double> NewRows(py::ssize_t rows, int dims, bool single) {
  if (single) return py::array_t<double>(std::vector<py::ssize_t>{dims});
  return py::array_t<double>(std::vector<py::ssize_t>{rows, dims});
}

// Pixels of points in the camera frame; NaN rows where the model has no projection.
py::array_t<double> ProjectPoints(const Camera& camera, const InArray& points) {
  py::ssize_t rows = 0;
  bool single = false;
  const double* in = PointRows(points, 3, "Camera.project: points", &rows, &single);
  py::array_t<double> result = NewRows(rows, 2, single);
  double* out = result.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t i = 0; i < rows; ++i) {
      const std::optional<Eigen::Vector2d> pixel =
          camera.Project(Eigen::Vector3d(in[3 * i], in[3 * i + 1], in[3 * i + 2]));
      out[2 * i] = pixel ? pixel->x() : kNaN;
      out[2 * i + 1] = pixel ? pixel->y() : kNaN;
    }
  }
  return result;
}

// Unit bearings of pixels; NaN rows where the model has no inverse.
py::array_t<double> UnprojectPixels(const Camera& camera, const InArray& pixels) {
  py::ssize_t rows = 0;
  bool single = false;
  const double* in = PointRows(pixels, 2, "Camera.unproject: pixels", &rows, &single);
  py::array_t<double> result = NewRows(rows, 3, single);
  double* out = result.mutable_data();
  {
    py::gil_scoped_release release;
    for (py::ssize_t i = 0; i < rows; ++i) {
      const std::optional<Eigen::Vector3d> bearing = camera.Unproject(Eigen::Vector2d(in[2 * i], in[2 * i + 1]));
      for (int k = 0; k < 3; ++k) out[3 * i + k] = bearing ? (*bearing)[k] : kNaN;
    }
  }
  return result;
}

py::array_t<bool> InImage(const Camera& camera, const InArray& pixels) {
  py::ssize_t rows = 0;
  bool single = false;
  const double* in = PointRows(pixels, 2, "Camera.is_in_image: pixels", &rows, &single);
  py::array_t<bool> result(std::vector<py::ssize_t>{rows});
  bool* out = result.mutable_data();
  for (py::ssize_t i = 0; i < rows; ++i) {
    out[i] = std::isfinite(in[2 * i]) && std::isfinite(in[2 * i + 1]) &&
             camera.IsInImage(Eigen::Vector2d(in[2 * i], in[2 * i + 1]));
  }
  return result;
}

Rigid3d RigidFromMatrix(const Eigen::Matrix4d& m) {
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if (!m.allFinite() || (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > kRigRotationTolerance ||
      r.determinant() < 0.0 || (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-12) {
    throw InputError("cam_from_rig: expected a rigid 4 x 4 transform (orthonormal rotation, last row 0 0 0 1)");
  }
  return Rigid3d::FromMatrix(m.topRows<3>());
}

Camera MakeCamera(const std::string& model, const std::vector<double>& params, int width, int height,
                  const std::string& name, const std::optional<Eigen::Matrix4d>& cam_from_rig) {
  const std::optional<CameraModelId> id = CameraModelFromName(model);
  if (!id) {
    throw InputError(StrCat("Camera: model: unknown model '", model,
                            "' (known: pinhole, radtan, kannala_brandt, mei, double_sphere)"));
  }
  std::vector<double> stored = params;
  // rig.json may omit radtan's k3; so may this.
  if (*id == CameraModelId::kRadTan && stored.size() == 8) stored.push_back(0.0);
  const std::string error = CameraParamsError(*id, stored);
  if (!error.empty()) throw InputError(StrCat("Camera: params: ", error));
  if (width <= 0 || height <= 0) throw InputError(StrCat("Camera: size must be positive, got ", width, " x ", height));
  Camera camera;
  camera.name = name;
  camera.model = *id;
  camera.params = stored;
  camera.width = width;
  camera.height = height;
  if (cam_from_rig) camera.cam_from_rig = RigidFromMatrix(*cam_from_rig);
  return camera;
}

const Camera& CameraAt(const Rig& rig, const py::object& key) {
  if (py::isinstance<py::str>(key)) {
    const int index = rig.FindCamera(key.cast<std::string>());
    if (index < 0) throw py::key_error("no camera '" + key.cast<std::string>() + "' in the rig");
    return rig.cameras[static_cast<size_t>(index)];
  }
  py::ssize_t index = key.cast<py::ssize_t>();
  if (index < 0) index += rig.NumCameras();
  if (index < 0 || index >= rig.NumCameras()) throw py::index_error("camera index out of range");
  return rig.cameras[static_cast<size_t>(index)];
}

}  // namespace

void BindCamera(py::module_& m) {
  py::class_<Camera>(m, "Camera",
                     "One camera of a rig: model, intrinsics, image size, extrinsics (docs/rig-json.md).")
      .def(py::init(&MakeCamera), py::arg("model"), py::arg("params"), py::arg("width"), py::arg("height"),
           py::arg("name") = "camera", py::arg("cam_from_rig") = py::none(),
           "A camera of a model (pinhole, radtan, kannala_brandt, mei, double_sphere) with its parameters in "
           "rig.json order; bad values raise InputError.")
      .def_readonly("name", &Camera::name)
      .def_property_readonly("model", [](const Camera& c) { return std::string(CameraModelName(c.model)); })
      .def_readonly("width", &Camera::width)
      .def_readonly("height", &Camera::height)
      .def_property_readonly("size", [](const Camera& c) { return py::make_tuple(c.width, c.height); },
                             "(width, height) in pixels")
      .def_property_readonly(
          "params", [](const Camera& c) { return py::array_t<double>(c.params.size(), c.params.data()); },
          "the model's parameters, in rig.json order (param_names)")
      .def_property_readonly("param_names", [](const Camera& c) { return CameraModelParamNames(c.model); })
      .def_property_readonly(
          "cam_from_rig", [](const Camera& c) { return Eigen::Matrix4d(c.cam_from_rig.ToMatrix4()); },
          "4 x 4 homogeneous transform from the rig frame to the camera frame")
      .def_property_readonly("mask_path", [](const Camera& c) -> py::object {
        if (c.mask_path.empty()) return py::none();
        return py::str(c.mask_path);
      })
      .def_property_readonly("mean_focal_length", &Camera::MeanFocalLength,
                             "pixels per radian at the principal point, mean of u and v")
      .def("project", &ProjectPoints, py::arg("points"),
           "Pixels (N x 2) of points in the camera frame (N x 3); NaN rows outside the model's domain. "
           "The image rectangle is not tested (is_in_image).")
      .def("unproject", &UnprojectPixels, py::arg("pixels"),
           "Unit bearings (N x 3) of pixels (N x 2); NaN rows where the model has no inverse.")
      .def("is_in_image", &InImage, py::arg("pixels"),
           "Whether each pixel (N x 2) is inside the image, OpenCV's pixel-centre convention.")
      .def("__repr__", [](const Camera& c) {
        return StrCat("<mcvo.Camera '", c.name, "' ", CameraModelName(c.model), " ", c.width, "x", c.height, ">");
      });

  py::class_<Rig>(m, "Rig", "A rigid rig of cameras (rig.json, docs/rig-json.md).")
      .def_static(
          "load", [](const py::object& path) { return ReadRig(PathString(path)); }, py::arg("path"),
          "Reads and validates a rig.json; problems raise InputError naming the file and JSON path.")
      .def_static(
          "from_json",
          [](const std::string& text, const std::string& source, const py::object& base_dir) {
            return ParseRigJson(text, source, base_dir.is_none() ? std::string(".") : PathString(base_dir));
          },
          py::arg("text"), py::arg("source") = "<string>", py::arg("base_dir") = py::none(),
          "As load, from rig.json text.")
      .def(
          "save", [](const Rig& rig, const py::object& path) { WriteRig(PathString(path), rig); }, py::arg("path"),
          "Writes the rig as rig.json (atomically).")
      .def_readonly("cameras", &Rig::cameras)
      .def_property_readonly("names",
                             [](const Rig& rig) {
                               std::vector<std::string> names;
                               for (const Camera& c : rig.cameras) names.push_back(c.name);
                               return names;
                             })
      .def("__len__", &Rig::NumCameras)
      .def("__getitem__", &CameraAt, py::arg("key"), py::return_value_policy::copy,
           "A camera by name or index.")
      .def("__repr__", [](const Rig& rig) { return StrCat("<mcvo.Rig of ", rig.NumCameras(), " cameras>"); });
}

}  // namespace mcvo::python
