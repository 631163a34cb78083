// Images stored inside one container file (a ROS bag: rosbag_reader.cc)
// instead of one file each, streamed from it without extraction to disk.
//
// A reader of such a layout lists each image in DatasetFrame::images as a
// path below the container file, <container>/<member> (a bag's
// run.bag/cam0/image_raw/12: message 12 of topic /cam0/image_raw), and
// registers the open container. While the registration lives (the reader
// keeps it in DatasetIndex::image_container, so as long as any copy of the
// index does), every reader of image paths takes such a path from the
// container: ReadImageFile and FrameStream decode it, and Sha256OfImage
// hashes its stored bytes (run.json). Everything else that handles image
// paths (missing = empty path, logs, the COLMAP export's names) is unchanged.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core/mat.hpp>

namespace mcvo {

class ImageContainer {
 public:
  virtual ~ImageContainer() = default;
  // The decode of a member, as ReadImageFile gives a file's (colour BGR,
  // grey, 16-bit as stored). Thread-safe. Throws InputError naming the
  // container and the member (for a bag: topic and message index).
  virtual cv::Mat Decode(const std::filesystem::path& member) const = 0;
  // SHA-256 (hex) of the member's stored bytes. Thread-safe; throws as Decode.
  virtual std::string Sha256(const std::filesystem::path& member) const = 0;
};

// Registers `container` as the source of the paths below `file` until the
// returned handle is destroyed. A later registration of the same file takes
// precedence while it lives.
std::shared_ptr<const void> RegisterImageContainer(const std::filesystem::path& file,
                                                   std::shared_ptr<const ImageContainer> container);

// The registered container file `image` lies below (compared as absolute,
// lexically normal paths), or an empty path when it is not a member of one.
std::filesystem::path ImageContainerFile(const std::filesystem::path& image);

// The decode of a registered container's member; empty Mat when `image` is
// not one (the caller then reads the file).
cv::Mat DecodeContainerImage(const std::filesystem::path& image, bool* is_member);

// SHA-256 (hex) of an image: the file's bytes, or a container member's
// stored bytes. Throws InputError naming the file when it cannot be read.
std::string Sha256OfImage(const std::filesystem::path& image);

}  // namespace mcvo
