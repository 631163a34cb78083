// Relocalisation after a tracking loss, for `mcvo run` (private to
// pipeline/). The odometry stage links a segment that starts after a loss to
// the one before it by constant velocity (odometry_stage.h); here each such
// segment is located in the previous segment's map instead, as loop
// verification does: the previous segment's last
// loop.relocalise_map_keyframes keyframes (ORB at their landmarks' pixels,
// with the landmarks' positions) form a bag-of-words database, and each of
// the new segment's first loop.relocalise_query_keyframes keyframes is
// matched against its best candidates by BoW and solved by the generalized
// rig PnP over all cameras (loop/loop_closer.h, Relocalise). When none
// verifies that way (after a loss the tracks are new, and ORB's corners
// rarely match descriptors taken at the tracker's), the map's landmarks are
// re-tracked into the query keyframes by LK, started at their projection
// under the constant-velocity link, and the same rig PnP and bounds
// decide. The verified query with the most inliers places the segment (and every later one,
// chained to it) in the previous segment's world; a rig with metric scale
// keeps its own scale (the new segment initialised it from the rig). A
// segment no query verifies keeps its constant-velocity link.
//
// Logged per segment as a "relocalise" scale_log line (applied or not, with
// the query and map frames, inliers, cameras and how far it moved the
// segment from the constant-velocity link). Deterministic: keyframes in
// frame order, features per camera in fixed slots.
#pragma once

#include <vector>

#include "mcvo/colmap/colmap_model.h"
#include "mcvo/config/pipeline_options.h"
#include "mcvo/dataset/dataset.h"
#include "mcvo/loop/loop_closer.h"
#include "mcvo/loop/vocabulary.h"
#include "odometry_stage.h"

namespace mcvo::pipeline_internal {

// A keyframe for the loop closer: its images decoded (in parallel over
// cameras, each into its own slot) and its landmark observations with their
// world points. Throws InputError naming an image that cannot be read.
// colors (optional): per camera, the COLMAP export's colours at the
// keyframe's observation pixels of that camera (colmap_model.h
// SampleColmapColors), from the one decode that also gives the grey image
// (dataset.h GreyOfDecodedImage, as the frontend's).
LoopKeyframe ToLoopKeyframe(const DatasetIndex& index, const KeyframeEstimate& keyframe, int threads,
                            std::vector<ColmapColorSamples>* colors = nullptr);
// The same without reading the images: one empty Mat per camera.
LoopKeyframe LoopKeyframeWithoutImages(const KeyframeEstimate& keyframe, int num_cameras);
// The COLMAP colours of the keyframe's observations in `camera`, from that
// camera's image decoded (DecodeColmapColorImage).
ColmapColorSamples SampleKeyframeColors(const cv::Mat& decoded, const KeyframeEstimate& keyframe, int camera);

struct RelocalisationSummary {
  int attempted = 0;  // segments after the first with keyframes on both sides
  int applied = 0;
};

// Moves the later segments of `odometry` (after LinkSegments) into the
// previous segment's world where relocalisation verifies; appends the
// scale_log lines (kept in frame order).
RelocalisationSummary RelocaliseSegments(const DatasetIndex& index, const Vocabulary& vocabulary,
                                         const LoopOptions& options, int threads, OdometryOutput* odometry);

}  // namespace mcvo::pipeline_internal
