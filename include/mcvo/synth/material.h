// Surface materials of the synthetic scenes and their band-limited,
// procedural shading (implemented in src/synth/texture.cc).
//
// Texture coordinates are metres on the surface: u along Quad::axis_u, v
// along Quad::axis_v, from the quad's origin corner. For vertical surfaces v
// points up (v = 0 at the bottom edge), so facades know where floors are.
#pragma once

#include <cstdint>
#include <string_view>

namespace mcvo::synth {

enum class Material : uint8_t {
  kSky,            // not a surface: what a ray that hits nothing sees
  kAsphalt,        // road surface: fine multi-scale noise, patches, cracks
  kRoadMarking,    // asphalt with lane lines / crosswalk stripes (quad-local layout)
  kSidewalk,       // paving slabs with joints
  kFacadePlaster,  // building facade: plaster with a grid of windows per floor
  kFacadeBrick,    // building facade: bricks with a grid of windows per floor
  kShopFront,      // ground floor of a facade: glass, doors, signs, posters
  kPoster,         // high-texture, unique content (ads, graffiti), for good features
  kWallPaint,      // indoor wall: nearly textureless paint (long weak-texture segments)
  kFloorTile,      // indoor floor tiles with grout
  kCeiling,        // indoor ceiling panels with lights
  kWood,           // furniture, doors
  kMetal,          // cabinets, machines, car bodies
  kGrass,          // open terrain
  kRock,           // boulders, hills, distant structure
  kFoliage,        // trees / bushes: high-frequency, high-contrast
  kMarker,         // test target: a white disc (radius 0.35 of the quad's shorter side) on black, centred
};

inline constexpr int kNumMaterials = static_cast<int>(Material::kMarker) + 1;

std::string_view MaterialName(Material material);

// Mean albedo in [0, 1] of the surface over a square footprint of side
// `footprint_m` (metres on the surface) centred at (u_m, v_m). Every detail
// finer than the footprint is averaged out rather than point-sampled (the
// procedural equivalent of a mip-map lookup), so textures neither alias nor
// flicker as the camera moves. `extent_u_m`, `extent_v_m` are the quad's
// size (layouts such as windows and markings are placed relative to it).
// `seed` varies the pattern per surface. Pure function: deterministic and
// thread-safe.
float ShadeSurface(Material material, uint32_t seed, double u_m, double v_m, double footprint_m,
                   double extent_u_m, double extent_v_m);

// Radiance in [0, 1] of the sky in world direction (x, y, z), z up: a smooth
// gradient with soft, low-contrast clouds (no trackable corners).
float ShadeSky(double dx, double dy, double dz);

}  // namespace mcvo::synth
