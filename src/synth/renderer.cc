// Ray-casting renderer (renderer.h): a per-camera cache of sample bearings,
// the per-pixel sample loop, and the row-parallel driver.
#include "mcvo/synth/renderer.h"

#include "mcvo/util/hash.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "mcvo/synth/material.h"
#include "mcvo/util/error.h"
#include "mcvo/util/parallel.h"

namespace mcvo::synth {
namespace {

// Calls row_fn(y) for y in [0, rows) on `threads` threads (0: all cores;
// util/parallel.h); row_fn must write only its own row, so the result does
// not depend on which thread ran which row.
template <typename RowFn>
void ForEachRow(int rows, int threads, RowFn&& row_fn) {
  ParallelFor(rows, threads, [&](int y) { row_fn(y); });
}

// Bearings of every sample of a camera (the fixed stratified grid), and per
// pixel the angular pitch and the angle from the optical axis.
struct CameraRays {
  int width = 0;
  int height = 0;
  int n = 1;  // samples per axis
  // 3 floats per sample, sample (i, j) of pixel (x, y) at
  // ((y * width + x) * n + j) * n + i; x component NaN outside the domain.
  std::vector<float> bearings;
  std::vector<float> centres;           // 3 floats per pixel: bearing of the pixel centre, NaN outside
  std::vector<float> sample_angle_rad;  // per pixel: angular size of one sample
  std::vector<float> axis_angle_rad;    // per pixel: angle of the pixel's mean bearing from +z
  std::vector<uint8_t> all_valid;       // per pixel: centre and every sample inside the domain

  size_t Bytes() const {
    return sizeof(float) *
               (bearings.size() + centres.size() + sample_angle_rad.size() + axis_angle_rad.size()) +
           all_valid.size();
  }
};

constexpr float kInvalid = std::numeric_limits<float>::quiet_NaN();

// Angular pitch (radians per pixel) at pixel (x, y) from the bearings of the
// neighbouring pixel centres: sqrt(|db/du x db/dv|), the square root of the
// pixel's solid angle. Central differences, one-sided at the domain edge,
// 1 / MeanFocalLength when neither exists.
double PixelAngle(const std::vector<Eigen::Vector3d>& centres, const std::vector<char>& valid, int width,
                  int height, int x, int y, double fallback) {
  auto at = [&](int xx, int yy) -> const Eigen::Vector3d* {
    if (xx < 0 || yy < 0 || xx >= width || yy >= height) return nullptr;
    const size_t i = static_cast<size_t>(yy) * width + xx;
    return valid[i] ? &centres[i] : nullptr;
  };
  auto derivative = [&](int dx, int dy, Eigen::Vector3d* d) {
    const Eigen::Vector3d* plus = at(x + dx, y + dy);
    const Eigen::Vector3d* minus = at(x - dx, y - dy);
    const Eigen::Vector3d* centre = at(x, y);
    if (plus != nullptr && minus != nullptr) {
      *d = 0.5 * (*plus - *minus);
    } else if (centre != nullptr && plus != nullptr) {
      *d = *plus - *centre;
    } else if (centre != nullptr && minus != nullptr) {
      *d = *centre - *minus;
    } else {
      return false;
    }
    return true;
  };
  Eigen::Vector3d du, dv;
  if (!derivative(1, 0, &du) || !derivative(0, 1, &dv)) return fallback;
  const double solid_angle = du.cross(dv).norm();
  return solid_angle > 0.0 ? std::sqrt(solid_angle) : fallback;
}

std::shared_ptr<const CameraRays> BuildCameraRays(const Camera& camera, int n, int threads) {
  auto rays = std::make_shared<CameraRays>();
  const int w = camera.width;
  const int h = camera.height;
  rays->width = w;
  rays->height = h;
  rays->n = n;
  const size_t num_pixels = static_cast<size_t>(w) * h;
  rays->bearings.assign(num_pixels * n * n * 3, kInvalid);
  rays->centres.assign(num_pixels * 3, kInvalid);
  rays->sample_angle_rad.assign(num_pixels, 0.0f);
  rays->axis_angle_rad.assign(num_pixels, 0.0f);
  rays->all_valid.assign(num_pixels, 0);

  std::vector<Eigen::Vector3d> centres(num_pixels, Eigen::Vector3d::Zero());
  std::vector<char> valid(num_pixels, 0);
  ForEachRow(h, threads, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (const auto b = camera.Unproject(Eigen::Vector2d(x, y))) {
        centres[p] = *b;
        valid[p] = 1;
        for (int i = 0; i < 3; ++i) rays->centres[3 * p + i] = static_cast<float>((*b)[i]);
      }
    }
  });
  const double fallback = 1.0 / camera.MeanFocalLength();
  ForEachRow(h, threads, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      rays->sample_angle_rad[p] = static_cast<float>(PixelAngle(centres, valid, w, h, x, y, fallback) / n);
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      bool all_valid = valid[p] != 0;
      for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
          const Eigen::Vector2d pixel(x - 0.5 + (i + 0.5) / n, y - 0.5 + (j + 0.5) / n);
          const auto b = camera.Unproject(pixel);
          all_valid &= b.has_value();
          if (!b) continue;
          float* out = &rays->bearings[((p * n + j) * n + i) * 3];
          out[0] = static_cast<float>(b->x());
          out[1] = static_cast<float>(b->y());
          out[2] = static_cast<float>(b->z());
          mean += *b;
        }
      }
      rays->all_valid[p] = all_valid ? 1 : 0;
      rays->axis_angle_rad[p] =
          mean.squaredNorm() > 0.0 ? static_cast<float>(std::atan2(mean.head<2>().norm(), mean.z())) : 0.0f;
    }
  });
  return rays;
}

// Process-wide cache of CameraRays, most recently used first, bounded by
// kRayCacheMaxBytes (the entry just added always stays).
struct RayCacheKey {
  int model = 0;
  std::vector<double> params;
  int width = 0;
  int height = 0;
  int n = 0;
  bool operator==(const RayCacheKey& o) const {
    return std::tie(model, params, width, height, n) == std::tie(o.model, o.params, o.width, o.height, o.n);
  }
};

class RayCache {
 public:
  std::shared_ptr<const CameraRays> Get(const Camera& camera, int n, int threads) {
    const RayCacheKey key{static_cast<int>(camera.model), camera.params, camera.width, camera.height, n};
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (auto it = entries_.begin(); it != entries_.end(); ++it) {
        if (it->first == key) {
          entries_.splice(entries_.begin(), entries_, it);
          return entries_.front().second;
        }
      }
    }
    // Built outside the lock: other cameras can render meanwhile. Two
    // threads building the same camera build identical rays; one is kept.
    std::shared_ptr<const CameraRays> rays = BuildCameraRays(camera, n, threads);
    std::lock_guard<std::mutex> lock(mutex_);
    entries_.emplace_front(key, rays);
    size_t bytes = 0;
    for (auto it = entries_.begin(); it != entries_.end();) {
      bytes += it->second->Bytes();
      if (it != entries_.begin() && bytes > kRayCacheMaxBytes) {
        bytes -= it->second->Bytes();
        it = entries_.erase(it);
      } else {
        ++it;
      }
    }
    return rays;
  }

  void Clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    entries_.clear();
  }

 private:
  std::mutex mutex_;
  std::list<std::pair<RayCacheKey, std::shared_ptr<const CameraRays>>> entries_;
};

RayCache& GlobalRayCache() {
  static RayCache* cache = new RayCache();  // never destroyed: usable during static destruction
  return *cache;
}

// Radiance of a surface point (renderer.h, step 3): `normal` unit, facing
// the ray origin; `direction` the unit ray.
double SurfaceRadiance(const Quad& quad, double distance, const Eigen::Vector3d& normal, double u_m,
                       double v_m, const Eigen::Vector3d& direction, double sample_angle,
                       const Eigen::Vector3d& sun) {
  const double cos_incidence = std::abs(direction.dot(normal));
  const double footprint_m = distance * sample_angle / std::sqrt(std::max(cos_incidence, 0.05));
  const double albedo = ShadeSurface(quad.material, quad.texture_seed, u_m, v_m, footprint_m,
                                     quad.axis_u.norm(), quad.axis_v.norm());
  return albedo * (kAmbient + kDiffuse * std::max(0.0, normal.dot(sun)));
}

// Marks, in the centre-ray pass of adaptive supersampling, a pixel centre
// outside the camera model's domain and a centre ray that hit a moving
// object (whose quads are in the object frame).
const Quad kOutsideDomain;
const Quad kMovingObject;

// Linear radiance in [0, 1] seen along a unit world ray.
double Radiance(const Scene& scene, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                int64_t t_ns, double sample_angle, double max_distance, const Eigen::Vector3d& sun) {
  const std::optional<Hit> hit = scene.Intersect(origin, direction, t_ns, 1e-4, max_distance);
  if (!hit) return ShadeSky(direction.x(), direction.y(), direction.z());
  return SurfaceRadiance(*hit->quad, hit->distance, hit->normal, hit->u_m, hit->v_m, direction, sample_angle,
                         sun);
}

// What the ray through a pixel centre hits: a static quad, nullptr (the sky)
// or &kMovingObject.
const Quad* CentreHit(const Scene& scene, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                      int64_t t_ns, double max_distance) {
  const std::optional<Hit> hit = scene.Intersect(origin, direction, t_ns, 1e-4, max_distance);
  if (!hit) return nullptr;
  return hit->moving_object >= 0 ? &kMovingObject : hit->quad;
}

// Radiance along a ray known to meet static `quad` first (adaptive
// supersampling): the ray-plane intersection with the formulas of Scene's
// ray-quad test, no scene traversal. nullopt when the ray misses the quad's
// rectangle or distance range; the caller then casts the ray.
std::optional<double> RadianceOnQuad(const Quad& quad, const Eigen::Vector3d& origin,
                                     const Eigen::Vector3d& direction, double sample_angle,
                                     double max_distance, const Eigen::Vector3d& sun) {
  const Eigen::Vector3d normal = quad.axis_u.cross(quad.axis_v);
  const double denom = normal.dot(direction);
  if (!(std::abs(denom) > 1e-12)) return std::nullopt;
  const double t = normal.dot(quad.origin - origin) / denom;
  if (!(t > 1e-4 && t < max_distance)) return std::nullopt;
  const Eigen::Vector3d rel = origin + t * direction - quad.origin;
  const double length_u2 = quad.axis_u.squaredNorm();
  const double length_v2 = quad.axis_v.squaredNorm();
  const double a = rel.dot(quad.axis_u) / length_u2;
  const double b = rel.dot(quad.axis_v) / length_v2;
  if (!(a >= 0.0 && a <= 1.0 && b >= 0.0 && b <= 1.0)) return std::nullopt;
  const Eigen::Vector3d facing = (denom < 0.0 ? normal : Eigen::Vector3d(-normal)).normalized();
  return SurfaceRadiance(quad, t, facing, a * std::sqrt(length_u2), b * std::sqrt(length_v2), direction,
                         sample_angle, sun);
}

// The quad (or nullptr: sky) that the centre rays of pixel (x, y) and of its
// 8 neighbours inside the image all hit, or &kOutsideDomain when they differ
// or are not a static quad or the sky. A straight edge that crosses the
// pixel square separates its centre from at least one of these neighbour
// centres (the farthest one along the edge normal is >= 1 px away, the
// square's corners only 0.71 px), so such a pixel holds no geometric edge,
// only features narrower than the gaps between centre rays could hide there.
const Quad* SameQuadAround(const std::vector<const Quad*>& centre_quad, int width, int height, int x, int y) {
  const Quad* quad = centre_quad[static_cast<size_t>(y) * width + x];
  if (quad == &kOutsideDomain || quad == &kMovingObject) return &kOutsideDomain;
  for (int yy = std::max(0, y - 1); yy <= std::min(height - 1, y + 1); ++yy) {
    for (int xx = std::max(0, x - 1); xx <= std::min(width - 1, x + 1); ++xx) {
      if (centre_quad[static_cast<size_t>(yy) * width + xx] != quad) return &kOutsideDomain;
    }
  }
  return quad;
}

// Standard normal draw for pixel `pixel` of (seed, frame, camera): Box-Muller
// on two hashed uniforms.
double PixelGaussian(uint64_t seed, int frame, int camera_index, size_t pixel) {
  const uint64_t h1 = HashWords({seed, 0x6e6f697365ULL /*"noise"*/, static_cast<uint64_t>(frame),
                                 static_cast<uint64_t>(camera_index), pixel});
  const uint64_t h2 = SplitMix64(h1);
  const double u1 = OpenUnitFromHash(h1);
  const double u2 = OpenUnitFromHash(h2);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace

void ClearRenderCache() { GlobalRayCache().Clear(); }

cv::Mat RenderImageAtPoses(const Scene& scene, const Rig& rig, int camera_index,
                           const std::vector<Rigid3d>& world_from_rig_samples,
                           const std::vector<int64_t>& t_ns_samples, int frame,
                           const RenderOptions& options) {
  options.Check();
  MCVO_CHECK_MSG(camera_index >= 0 && camera_index < rig.NumCameras(), "camera index ", camera_index);
  MCVO_CHECK(!world_from_rig_samples.empty() && world_from_rig_samples.size() == t_ns_samples.size());
  const Camera& camera = rig.cameras[camera_index];
  MCVO_CHECK_MSG(camera.width > 0 && camera.height > 0, "camera '", camera.name, "' has no image size");
  cv::Mat image(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  const RenderEffects& effects = options.effects;
  if (effects.IsBlackout(camera_index, frame)) return image;

  const int n = options.samples_per_axis;
  const std::shared_ptr<const CameraRays> rays = GlobalRayCache().Get(camera, n, options.threads);

  const size_t num_instants = t_ns_samples.size();
  std::vector<Eigen::Matrix3d> world_from_cam_rotation(num_instants);
  std::vector<Eigen::Vector3d> camera_centre_in_world(num_instants);
  const Rigid3d rig_from_cam = camera.cam_from_rig.Inverse();
  double t_mean_ns = 0.0;
  for (size_t k = 0; k < num_instants; ++k) {
    const Rigid3d world_from_cam = world_from_rig_samples[k] * rig_from_cam;
    world_from_cam_rotation[k] = world_from_cam.RotationMatrix();
    camera_centre_in_world[k] = world_from_cam.translation;
    t_mean_ns += static_cast<double>(t_ns_samples[k] - t_ns_samples[0]) / num_instants;
  }
  const double gain =
      ExposureGain(effects, options.seed, camera_index, t_ns_samples[0] + std::llround(t_mean_ns));
  const double scale = 255.0 * gain / (static_cast<double>(n) * n * num_instants);
  const Eigen::Vector3d sun = SunDirection();
  const int samples = n * n;
  const int width = camera.width;
  const int height = camera.height;
  const size_t num_pixels = static_cast<size_t>(width) * height;
  const bool adaptive = options.adaptive_supersampling && n > 1;

  // Sum of the radiance of every sample of every instant, per pixel, added in
  // the same order (instant, then sample) whatever the thread count.
  std::vector<double> sum(num_pixels, 0.0);
  std::vector<const Quad*> centre_quad(adaptive ? num_pixels : 0);
  for (size_t k = 0; k < num_instants; ++k) {
    const Eigen::Vector3d& origin = camera_centre_in_world[k];
    auto world_direction = [&](const float* b) {
      return (world_from_cam_rotation[k] * Eigen::Vector3d(b[0], b[1], b[2])).normalized();
    };
    if (adaptive) {
      // Pass 1: what the ray through every pixel centre hits.
      ForEachRow(height, options.threads, [&](int y) {
        for (size_t p = static_cast<size_t>(y) * width, end = p + width; p < end; ++p) {
          const float* c = &rays->centres[3 * p];
          centre_quad[p] = std::isnan(c[0]) ? &kOutsideDomain
                                            : CentreHit(scene, origin, world_direction(c), t_ns_samples[k],
                                                        options.max_distance_m);
        }
      });
    }
    // Pass 2: every sample; where the pixel is known to see one static quad
    // or the sky only, without traversing the scene.
    ForEachRow(height, options.threads, [&](int y) {
      for (int x = 0; x < width; ++x) {
        const size_t p = static_cast<size_t>(y) * width + x;
        const Quad* known = adaptive && rays->all_valid[p] ? SameQuadAround(centre_quad, width, height, x, y)
                                                           : &kOutsideDomain;
        const float* bearing = &rays->bearings[p * samples * 3];
        const double sample_angle = rays->sample_angle_rad[p];
        for (int s = 0; s < samples; ++s) {
          const float* b = bearing + static_cast<ptrdiff_t>(3) * s;
          if (std::isnan(b[0])) continue;  // outside the model's domain: radiance 0
          const Eigen::Vector3d direction = world_direction(b);
          if (known == nullptr) {
            sum[p] += ShadeSky(direction.x(), direction.y(), direction.z());
            continue;
          }
          if (known != &kOutsideDomain) {
            if (const auto radiance =
                    RadianceOnQuad(*known, origin, direction, sample_angle, options.max_distance_m, sun)) {
              sum[p] += *radiance;
              continue;
            }
          }
          sum[p] +=
              Radiance(scene, origin, direction, t_ns_samples[k], sample_angle, options.max_distance_m, sun);
        }
      }
    });
  }

  LensBlur(effects.lens_blur_sigma_px, width, height, options.threads, &sum);
  const bool tone = effects.HasToneCurve();
  const bool sensor_noise = effects.HasSensorNoise();
  ForEachRow(height, options.threads, [&](int y) {
    uint8_t* out = image.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      const size_t p = static_cast<size_t>(y) * width + x;
      double value = scale * sum[p];
      if (effects.vignetting) value *= VignettingFalloff(rays->axis_angle_rad[p]);
      if (tone) value = ToneCurve(effects, value);
      if (effects.noise_sigma > 0.0) {
        value += effects.noise_sigma * std::sqrt(1.0 + std::max(0.0, value) / 255.0) *
                 PixelGaussian(options.seed, frame, camera_index, p);
      }
      if (sensor_noise) {
        const double variance = effects.sensor_noise_a * std::max(0.0, value) + effects.sensor_noise_b;
        value += std::sqrt(variance) * PixelGaussian(options.seed, frame, camera_index, p);
      }
      out[x] = static_cast<uint8_t>(std::clamp(std::floor(value + 0.5), 0.0, 255.0));
    }
  });
  return image;
}

}  // namespace mcvo::synth
