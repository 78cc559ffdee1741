// Where the exit direction of a node-sampled table jumps (docs/encodings.md, "Jumps"): for each
// node, the distance in grid cells to the nearest jump, which the decode uses to place a jump
// inside a cell instead of midway between the nodes on either side.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

namespace shrefract::bake {

// Bisections of a grid edge that a jump crosses: the crossing is located to 1 / 2^4 of a cell,
// where more bisections change the image little and each traces more rays (docs/encodings.md,
// "Placing the jump").
inline constexpr int kJumpBisections = 4;

// A traced view direction: the exit of its path and the direction the view ray travels (the exit
// of a path that went straight through), both in the same space.
struct TracedView {
  glm::vec3 exit{0.0f};
  glm::vec3 straight{0.0f};
  bool trapped = false;  // stopped at the interaction cap: its exit is no side of a jump
};

// Distances, in grid cells, from every node of an N x N hemi-octahedral table (index j * N + i) to
// the nearest jump of the exit direction, at most gpu::kJumpDistanceMaxCells. nodes[d] is node d
// as traced; trace(x, y) traces the view direction at fractional grid coordinates (x, y).
//
// A grid edge whose nodes were both traced to an exit (neither trapped) holds a jump where they
// disagree as the decode judges corners (one node's exit, moved by the change of the
// straight-through direction to the other node, more than midway between the angles of
// jumpCosines(n) from the other's exit); the crossing is bisected, each traced point
// going to the side whose moved exit it is nearer. A node with crossings at tx along its row and ty
// along its column is sqrt(1 / (1/tx^2 + 1/ty^2)) from a straight jump through both, tx or ty with
// one, kJumpDistanceMaxCells with none.
std::vector<float> jumpDistances(uint32_t n, std::span<const TracedView> nodes,
                                 const std::function<TracedView(float x, float y)>& trace);

}  // namespace shrefract::bake
