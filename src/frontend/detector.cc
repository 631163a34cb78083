// CreateDetector: the one place that maps DetectorType to an implementation.
#include "mcvo/frontend/detector.h"

#include "classic_detectors.h"
#include "mcvo/frontend/keypoint_net.h"
#include "mcvo/util/error.h"

namespace mcvo {

std::unique_ptr<Detector> CreateDetector(const FrontendOptions& options) {
  switch (options.detector) {
    case DetectorType::kShiTomasi:
      return internal::MakeShiTomasiDetector();
    case DetectorType::kOrb:
      return internal::MakeOrbDetector();
    case DetectorType::kXFeat:
    case DetectorType::kSuperPoint:
      if (options.model_path.empty()) {
        MCVO_THROW_INPUT("/frontend/model_path: required for detector \"",
                         options.detector == DetectorType::kXFeat ? "xfeat" : "superpoint", "\"");
      }
      return std::make_unique<KeypointNetDetector>(options.model_path, options);
  }
  MCVO_CHECK_MSG(false, "unknown detector type ", static_cast<int>(options.detector));
  return nullptr;
}

}  // namespace mcvo
