// The registry of open image containers (mcvo/dataset/image_container.h).
#include "mcvo/dataset/image_container.h"

#include <algorithm>
#include <mutex>
#include <utility>
#include <vector>

#include "mcvo/util/sha256.h"

namespace mcvo {
namespace {

namespace fs = std::filesystem;

struct Registration {
  fs::path file;  // absolute, lexically normal
  std::weak_ptr<const ImageContainer> container;
  const void* token = nullptr;
};

struct Registry {
  std::mutex mutex;
  std::vector<Registration> entries;  // latest last
};

Registry& GetRegistry() {
  static Registry* registry = new Registry();  // never destroyed: handles may outlive main's statics
  return *registry;
}

fs::path Normal(const fs::path& path) {
  std::error_code ec;
  fs::path absolute = fs::absolute(path, ec);
  return (ec ? path : absolute).lexically_normal();
}

// The container and member of `image`, when it lies below a registered file.
std::pair<std::shared_ptr<const ImageContainer>, fs::path> Find(const fs::path& image,
                                                                fs::path* file = nullptr) {
  Registry& registry = GetRegistry();
  std::lock_guard<std::mutex> lock(registry.mutex);
  if (registry.entries.empty()) return {};
  const fs::path normal = Normal(image);
  for (auto it = registry.entries.rbegin(); it != registry.entries.rend(); ++it) {
    const auto [end_file, end_image] =
        std::mismatch(it->file.begin(), it->file.end(), normal.begin(), normal.end());
    if (end_file != it->file.end() || end_image == normal.end()) continue;
    std::shared_ptr<const ImageContainer> container = it->container.lock();
    if (!container) continue;
    fs::path member;
    for (auto part = end_image; part != normal.end(); ++part) member /= *part;
    if (file != nullptr) *file = it->file;
    return {std::move(container), std::move(member)};
  }
  return {};
}

}  // namespace

std::shared_ptr<const void> RegisterImageContainer(const fs::path& file,
                                                   std::shared_ptr<const ImageContainer> container) {
  auto token = std::make_shared<int>(0);
  const void* key = token.get();
  {
    Registry& registry = GetRegistry();
    std::lock_guard<std::mutex> lock(registry.mutex);
    registry.entries.push_back({Normal(file), container, key});
  }
  // The handle unregisters when the last copy goes; it also keeps the container alive.
  return std::shared_ptr<const void>(key, [token, container](const void* k) {
    Registry& registry = GetRegistry();
    std::lock_guard<std::mutex> lock(registry.mutex);
    registry.entries.erase(std::remove_if(registry.entries.begin(), registry.entries.end(),
                                          [&](const Registration& r) { return r.token == k; }),
                           registry.entries.end());
  });
}

fs::path ImageContainerFile(const fs::path& image) {
  fs::path file;
  return Find(image, &file).first ? file : fs::path();
}

cv::Mat DecodeContainerImage(const fs::path& image, bool* is_member) {
  const auto [container, member] = Find(image);
  *is_member = container != nullptr;
  return container ? container->Decode(member) : cv::Mat();
}

std::string Sha256OfImage(const fs::path& image) {
  const auto [container, member] = Find(image);
  return container ? container->Sha256(member) : Sha256File(image);
}

}  // namespace mcvo
