#include <shrefract/bake/fit.h>

#include <algorithm>
#include <glm/geometric.hpp>

namespace shrefract::bake {

void smoothSpatially(std::vector<float>& coeffs, size_t stride, const std::vector<glm::vec3>& positions,
                     const std::vector<std::array<uint32_t, 2>>& adjacency, uint32_t count) {
  const size_t n = positions.size();
  if (n == 0 || count == 0) return;
  std::vector<std::vector<uint32_t>> adj(n);
  for (const auto& e : adjacency) {
    if (e[0] >= n || e[1] >= n || e[0] == e[1]) continue;
    adj[e[0]].push_back(e[1]);
    adj[e[1]].push_back(e[0]);
  }
  for (auto& a : adj) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  std::vector<float> out(coeffs.size());
  std::vector<uint32_t> candidates;
  for (size_t s = 0; s < n; ++s) {
    // Rings of the adjacency graph around s, widened (up to 4 rings) until there are enough.
    candidates = adj[s];
    std::vector<uint32_t> frontier = adj[s];
    for (int ring = 1; ring < 4 && candidates.size() < count && !frontier.empty(); ++ring) {
      std::vector<uint32_t> next;
      for (uint32_t a : frontier)
        for (uint32_t b : adj[a])
          if (b != s && !std::binary_search(candidates.begin(), candidates.end(), b)) next.push_back(b);
      std::sort(next.begin(), next.end());
      next.erase(std::unique(next.begin(), next.end()), next.end());
      candidates.insert(candidates.end(), next.begin(), next.end());
      std::sort(candidates.begin(), candidates.end());
      frontier.swap(next);
    }
    const glm::vec3 p = positions[s];
    std::sort(candidates.begin(), candidates.end(), [&](uint32_t a, uint32_t b) {
      const float da = glm::dot(positions[a] - p, positions[a] - p);
      const float db = glm::dot(positions[b] - p, positions[b] - p);
      return da < db || (da == db && a < b);
    });
    const size_t k = std::min<size_t>(count, candidates.size());
    for (size_t j = 0; j < stride; ++j) {
      double sum = static_cast<double>(coeffs[s * stride + j]);
      for (size_t c = 0; c < k; ++c) sum += static_cast<double>(coeffs[size_t(candidates[c]) * stride + j]);
      out[s * stride + j] = static_cast<float>(sum / double(k + 1));
    }
  }
  coeffs.swap(out);
}

}  // namespace shrefract::bake
