// The medium a field's front surfaces enclose, for the run-time tint (one colour model: the
// light transmitted through a front surface takes the colour of the medium behind it).
#include <shrefract/field.h>

#include <cmath>
#include <vector>

namespace shrefract {

std::array<float, 3> frontMediumColor(const Field& field) {
  if (field.media.size() < 2) return {1.0f, 1.0f, 1.0f};
  const float outside = field.media[0].ior > 0.0f ? field.media[0].ior : 1.0f;
  // Each vertex's frontIor is n_inside / n_outside of the surface there: it names its medium.
  std::vector<size_t> votes(field.media.size(), 0);
  for (float front : field.mesh.frontIor) {
    size_t best = 1;
    for (size_t m = 2; m < field.media.size(); ++m)
      if (std::fabs(field.media[m].ior / outside - front) < std::fabs(field.media[best].ior / outside - front))
        best = m;
    ++votes[best];
  }
  size_t chosen = 1;
  for (size_t m = 2; m < votes.size(); ++m)
    if (votes[m] > votes[chosen]) chosen = m;
  return field.media[chosen].color;
}

}  // namespace shrefract
