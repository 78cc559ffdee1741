// The hemi-octahedral grid of the Table and Pca encodings (shrefract/field.h), in the same float
// operations as engine/reference/src/field_decode.cpp (hemiOctFromDirection, hemiOctBilinear), so that
// the GPU picks the same cell and weights as the CPU decoder.
#ifndef SHREFRACT_HEMI_OCT_GLSL
#define SHREFRACT_HEMI_OCT_GLSL

// (u, v) in [0,1]^2 of a local direction of any length, z clamped to >= 0. Without a direction
// (the zero vector) the pole, as the SH evaluator treats it as +z.
vec2 hemiOctFromDirection(vec3 w) {
  float z = max(w.z, 0.0);
  float l1 = abs(w.x) + abs(w.y) + z;
  if (!(l1 > 0.0)) return vec2(0.5);
  float px = w.x / l1, py = w.y / l1;
  return clamp(vec2(px + py + 1.0, px - py + 1.0) * 0.5, 0.0, 1.0);
}

// The 4 nodes around a direction in an n x n grid (n >= 2; index j * n + i) and their bilinear
// weights: (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1) for the cell's lower corner (i, j).
struct HemiOctBilinear {
  uvec4 node;
  vec4 weight;
};

HemiOctBilinear hemiOctBilinear(vec3 w, uint n) {
  vec2 f = hemiOctFromDirection(w) * float(n - 1u);
  // The top row and column belong to the cell below them (u or v = 1 has no cell above).
  uvec2 cell = min(uvec2(f), uvec2(n - 2u));
  vec2 t = f - vec2(cell);
  uint corner = cell.y * n + cell.x;
  HemiOctBilinear b;
  b.node = uvec4(corner, corner + 1u, corner + n, corner + n + 1u);
  b.weight = vec4((1.0 - t.x) * (1.0 - t.y), t.x * (1.0 - t.y), (1.0 - t.x) * t.y, t.x * t.y);
  return b;
}

// Node (i, j)'s point on the octahedron |x| + |y| + z = 1 of an n x n grid, and its length
// (field_decode.cpp octahedronPoint, pointLength).
vec3 octahedronPoint(uint i, uint j, uint n) {
  float a = 2.0 * float(i) / float(n - 1u) - 1.0;  // p.x + p.y
  float b = 2.0 * float(j) / float(n - 1u) - 1.0;  // p.x - p.y
  float px = 0.5 * (a + b), py = 0.5 * (a - b);
  return vec3(px, py, max(0.0, 1.0 - abs(px) - abs(py)));
}

float pointLength(vec3 p) { return sqrt(p.x * p.x + p.y * p.y + p.z * p.z); }

// The unit direction of node (i, j) of an n x n grid (field_decode.h hemiOctDirection).
vec3 hemiOctDirection(uint i, uint j, uint n) {
  vec3 p = octahedronPoint(i, j, n);
  float len = pointLength(p);
  return vec3(p.x / len, p.y / len, p.z / len);
}

// The length of node `node`'s point on the octahedron (field_decode.cpp octahedronLength).
float octahedronLength(uint node, uint n) { return pointLength(octahedronPoint(node % n, node / n, n)); }

#endif  // SHREFRACT_HEMI_OCT_GLSL
