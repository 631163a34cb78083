// Street fixture of the renderer tests: a quad from its corner, axes,
// material and texture seed, and the static street both renderer_test.cc and
// sensor_effects_test.cc render (asphalt, two facades 8 m to the sides, a
// poster at the end: grey values from dark to bright).
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "mcvo/synth/scene.h"

namespace mcvo::test {

inline synth::Quad MakeQuad(const Eigen::Vector3d& origin, const Eigen::Vector3d& axis_u,
                            const Eigen::Vector3d& axis_v, synth::Material material, uint32_t seed) {
  synth::Quad quad;
  quad.origin = origin;
  quad.axis_u = axis_u;
  quad.axis_v = axis_v;
  quad.material = material;
  quad.texture_seed = seed;
  return quad;
}

// The street's static quads, added to `scene` (not built).
inline void AddStreetQuads(synth::Scene* scene) {
  using synth::Material;
  scene->AddQuad(MakeQuad({-50, -50, 0}, {200, 0, 0}, {0, 100, 0}, Material::kAsphalt, 1));
  scene->AddQuad(MakeQuad({-50, 8, 0}, {200, 0, 0}, {0, 0, 20}, Material::kFacadeBrick, 2));
  scene->AddQuad(MakeQuad({150, -8, 0}, {-200, 0, 0}, {0, 0, 20}, Material::kFacadePlaster, 3));
  scene->AddQuad(MakeQuad({40, 6, 0}, {0, -12, 0}, {0, 0, 8}, Material::kPoster, 4));
}

}  // namespace mcvo::test
