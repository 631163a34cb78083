// `mcvo info --rig FILE`: loads a rig.json and prints what mcvo understood
// from it (cameras, where each sits and looks in the rig frame, baselines and
// angles between optical axes), so a calibration can be checked by eye
// before a run. Later: --dataset DIR prints the dataset summary as well.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>

#include "command.h"
#include "mcvo/io/rig_io.h"
#include "mcvo/util/args.h"
#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo::tools {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::string Vec(const Eigen::Vector3d& v, int decimals) {
  return FormatFixed(v.x(), decimals) + " " + FormatFixed(v.y(), decimals) + " " +
         FormatFixed(v.z(), decimals);
}

// Position of the camera centre and direction of the optical axis (+z of the
// camera) in the rig frame.
Eigen::Vector3d CenterInRig(const Camera& camera) { return camera.cam_from_rig.Inverse().translation; }
Eigen::Vector3d AxisInRig(const Camera& camera) {
  return camera.cam_from_rig.rotation.conjugate() * Eigen::Vector3d::UnitZ();
}

void PrintRig(const std::string& path, const Rig& rig, std::ostream& out) {
  out << "rig: " << path << " (" << rig.NumCameras() << (rig.NumCameras() == 1 ? " camera" : " cameras")
      << "; positions in metres and directions in the rig frame)\n";
  for (int i = 0; i < rig.NumCameras(); ++i) {
    const Camera& camera = rig.cameras[static_cast<size_t>(i)];
    out << "\ncamera " << i << ": " << camera.name << "\n"
        << "  model      " << CameraModelName(camera.model) << ", " << camera.width << " x " << camera.height
        << " px\n  params    ";
    const std::vector<std::string> names = CameraModelParamNames(camera.model);
    for (size_t k = 0; k < camera.params.size(); ++k) {
      out << " " << (k < names.size() ? names[k] : "?") << "=" << FormatDouble(camera.params[k]);
    }
    out << "\n  position   " << Vec(CenterInRig(camera), 4) << "\n"
        << "  looks at   " << Vec(AxisInRig(camera), 4) << "\n";
    if (!camera.mask_path.empty()) out << "  mask       " << camera.mask_path << "\n";
  }
  if (rig.NumCameras() < 2) return;
  out << "\npairs: baseline [m], angle between optical axes [deg]\n";
  for (int i = 0; i < rig.NumCameras(); ++i) {
    for (int j = i + 1; j < rig.NumCameras(); ++j) {
      const Camera& a = rig.cameras[static_cast<size_t>(i)];
      const Camera& b = rig.cameras[static_cast<size_t>(j)];
      const double baseline = (CenterInRig(a) - CenterInRig(b)).norm();
      const double cosine = std::clamp(AxisInRig(a).dot(AxisInRig(b)), -1.0, 1.0);
      out << "  " << a.name << " - " << b.name << ": " << FormatFixed(baseline, 4) << " m, "
          << FormatFixed(std::acos(cosine) * kRadToDeg, 3) << " deg\n";
    }
  }
}

int RunInfo(int argc, const char* const* argv) {
  std::string rig_path;
  ArgParser args("mcvo info", "Loads a rig (and later a dataset) and prints what mcvo understood from it.");
  args.AddString("rig", &rig_path, "FILE", "rig.json to load and describe (docs/rig-json.md)");
  args.AddEpilog("example: mcvo info --rig config/rigs/kitti360.json\n");
  if (!args.Parse(argc, argv)) return kExitOk;
  if (rig_path.empty()) throw UsageError("nothing to describe: give --rig FILE (see --help)");
  const Rig rig = ReadRig(rig_path);
  PrintRig(rig_path, rig, std::cout);
  return kExitOk;
}

const CommandRegistrar kRegistrar("info", {"describe a rig.json (cameras, positions, baselines)", RunInfo});

}  // namespace
}  // namespace mcvo::tools
