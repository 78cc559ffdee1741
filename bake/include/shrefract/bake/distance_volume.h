// The Volume encoding's grid (field.h FieldVolume): the object's signed distance and surface
// normals on N^3 voxels, from which the decompression traces every sample's path for the eye
// (docs/encodings.md, "Volume").
#pragma once

#include <shrefract/assets/scene.h>
#include <shrefract/trace/tracer.h>
#include <shrefract/field.h>
#include <shrefract/result.h>

#include <cstdint>

namespace shrefract::bake {

// Voxels between the scene's bounding box and the grid's border on every side, so that the border
// reads "outside" and a path leaving the object crosses the surface before the grid ends.
inline constexpr uint32_t kVolumePaddingVoxels = 2;

// Builds the grid over the scene's bounding box (a cube of N voxels per side, the box's longest
// side spanning N - 1 - 2 * kVolumePaddingVoxels voxel spacings, centred). Voxels within
// kVolumeBandVoxels of a triangle store the exact distance to the nearest one, in voxels, and the
// interpolated vertex normal at the nearest point; the sign is that of a ray from the voxel's
// centre (inside when the first surface it meets faces away from it, tracer.firstHit). Voxels
// beyond the band store the band with the sign of their side, one side per connected region of
// such voxels: outside for the region of the grid's corner, and for every other region the side a
// ray from its first voxel finds (a pocket of air the band encloses, a sealed bubble, is air).
// Deterministic for any thread count.
// Errors (InvalidArgument): size outside kMinVolumeSize..kMaxVolumeSize; a scene that is not one
// medium in air (media.size() != 2, or a surface whose inner medium is not media[1] or outer not
// media[0]): the trace follows one interface rule, air to media[1].
Result<FieldVolume> buildDistanceVolume(const Scene& scene, const Tracer& tracer, uint32_t size, uint32_t threads);

// Why `scene` cannot be baked with the Volume encoding ("" when it can): the scene rule above.
std::string volumeSceneProblem(const Scene& scene);

}  // namespace shrefract::bake
