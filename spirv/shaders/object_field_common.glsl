// What the field shadings (object_field_body.glsl, object_volume_body.glsl) share: the object
// pass's fragment interface (object.vert's outputs, the push constants, the triangles' edge
// records) and its silhouette coverage (RendererCreateInfo::silhouetteCoverage). The includer
// includes shrefract/gpu_layout.h first.

layout(push_constant) uniform Push { ObjectPushConstants pc; };
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inFieldUv;
layout(location = 3) in float inFrontIor;
layout(location = 4) flat in uint inTriangle;  // the index of the fragment's triangle
layout(location = 0) out vec4 outColor;
layout(std430, set = 1, binding = kBindingTriangleEdges) readonly buffer TriangleEdgesBuffer {
  TriangleEdges triangleEdges[];
};
// true: the alpha written is the fragment's silhouette coverage, blended over what is drawn (the
// pipeline's blend state); false: 1, or the optical depth in kModeFieldExitDirection.
layout(constant_id = kSpecSilhouetteCoverage) const bool SILHOUETTE_COVERAGE = false;

// The share of its pixel a fragment covers where the surface turns away from the eye: one sample
// per pixel shades a pixel the silhouette crosses as if it were all glass (gpu_layout.h
// kSilhouetteCoverageScale says why c / |grad c| measures the distance). 1 on faces seen at an
// angle (c changes slowly across the pixel). Mirrored by cpu_reference.cpp silhouetteCoverage.
float silhouetteCoverage(float cosView) {
  float g = length(vec2(dFdxFine(cosView), dFdyFine(cosView)));
  return g > 0.0 ? clamp(0.5 + kSilhouetteCoverageScale * cosView / g, 0.0, 1.0) : 1.0;
}

// The share of its pixel a fragment covers beside its triangle's silhouette edges: an edge whose
// neighbour the eye sees from behind (or an open edge) bounds the glass, and a straight edge at
// distance d (pixels, along its normal; the fragment's centre is inside) covers about 0.5 + d of
// the pixel. The distance is the edge's in-plane distance over its change across the pixel
// (|d/dx| + |d/dy|: the pixel's width along the edge's normal). The least over the edges; 1
// without a silhouette edge. Flat faces give the cosine of silhouetteCoverage nothing to follow:
// this covers faceted glass (docs/technique.md, "Polygon silhouettes"). dPdx, dPdy: the
// position's fine derivatives. Mirrored by cpu_reference.cpp polygonCoverage.
float polygonCoverage(vec3 dPdx, vec3 dPdy) {
  TriangleEdges t = triangleEdges[inTriangle];
  float coverage = 1.0;
  for (int k = 0; k < 3; ++k) {
    vec4 across = t.neighbour[k];
    if (dot(across.xyz, pc.eyeObject.xyz) - across.w > 0.0) continue;  // the neighbour faces the eye
    vec4 edge = t.edge[k];
    float g = abs(dot(edge.xyz, dPdx)) + abs(dot(edge.xyz, dPdy));
    if (g > 0.0) coverage = min(coverage, clamp(0.5 + (dot(edge.xyz, inPosition) - edge.w) / g, 0.0, 1.0));
  }
  return coverage;
}
