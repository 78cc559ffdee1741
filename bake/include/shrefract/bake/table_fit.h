// Fits for the Table and Pca encodings (field.h, docs/encodings.md).
//
// Table: a sample's hemisphere functions as the N x N node values of a hemi-octahedral table,
// bilinear between nodes. The nodes are fitted by weighted least squares to the traced grid
// directions (each direction constrains the 4 nodes around it), with a small penalty on the
// differences between neighbouring nodes: nodes that no direction reaches take the harmonic
// blend of their neighbours, and the fit stays well conditioned at every N.
//
// With DirectionSampling::Nodes the bake traces the nodes' own directions (makeNodeGrid) and the
// fit is the identity (TableFit::atNodes): every node holds an exact traced exit, never a blend of
// exits from both sides of a jump, which is what the images measured better (docs/encodings.md,
// "Sampling").
//
// Pca: the per-sample tables of a whole field, as K weights of a basis learned from them (the
// leading eigenvectors of their second-moment matrix, uncentred, so that the first function
// carries the mean and K weights are the best rank-K least-squares approximation of the tables).
#pragma once

#include <shrefract/bake/fit.h>
#include <shrefract/result.h>

#include <cstdint>
#include <functional>
#include <vector>

namespace shrefract::bake {

// Relative weight of the neighbour-difference penalty: lambda = kDefaultTableRegularization *
// (solid angle per node). docs/encodings.md gives the measurement behind it.
inline constexpr double kDefaultTableRegularization = 1e-2;

// Grazing limit of a traced node direction: a node on the table's border (the horizon, z = 0) is
// traced at this z (about 1.1 deg above the tangent plane), because a path must enter the surface.
inline constexpr double kNodeMinZ = 0.02;

// The N x N node directions of the hemi-octahedral table in node order (j * N + i), border nodes
// lifted to kNodeMinZ; rows = columns = N, equal weights (2 pi / N^2: no fit reads them).
DirectionGrid makeNodeGrid(uint32_t n);
// The direction of that table at fractional grid coordinates (x, y) in [0, N - 1]^2, lifted as the
// border nodes are: what the bake traces between nodes (jump_distance.h).
glm::dvec3 nodeDirection(float x, float y, uint32_t n);

class TableFit {
 public:
  // Errors: n outside 2..kMaxTableSize, an empty grid, lambda not finite and > 0.
  static Result<TableFit> create(const DirectionGrid& grid, uint32_t n, double lambda = kDefaultTableRegularization);

  // The identity fit of a node grid (makeNodeGrid(n)): values at the nodes are the table.
  // Errors: n outside 2..kMaxTableSize.
  static Result<TableFit> atNodes(uint32_t n);

  uint32_t tableSize() const { return n_; }
  uint32_t nodeCount() const { return n_ * n_; }
  // values[d * channels + c] at grid direction d -> nodes[node * channels + c].
  void fit(const float* values, uint32_t channels, float* nodes) const;

 private:
  uint32_t n_ = 0;
  bool identity_ = false;
  std::vector<uint32_t> gridNodes_;  // 4 per grid direction
  std::vector<float> gridWeights_;   // 4 per grid direction: solid angle * bilinear weight
  std::vector<float> inverse_;       // nodeCount^2: the inverse of the normal matrix, row-major
};

// Weights of the Pca fit, D = diag(node weight * channel weight), the basis being the leading
// eigenvectors of the weighted tables' second moments (stored unweighted, in the data's units).
// Channels: the decoded error that matters is angular, so x, y, z count fully; tau and throughput
// are scaled to a comparable range (1 / their RMS, at most 1). Nodes: sqrt(max(z, kPcaMinNodeCosine))
// of the node's direction, so that the squared error is weighted by the cosine, as often as a view
// direction is seen (a surface's projected area); directions near the horizon, which the paths
// of faceted and nested glass make the hardest, then take fewer functions from the ones the
// image sees (docs/encodings.md, "Pca").
inline constexpr double kPcaMinNodeCosine = 0.01;

struct PcaBasis {
  uint32_t components = 0;
  uint32_t tableSize = 0;
  uint32_t channels = 0;
  std::vector<float> basis;  // field.h layout: (k * N^2 + node) * channels + c
  std::vector<float> scale;  // N^2 * channels: the weights D the basis was fitted with (see above)
};

// tables: samples x (N^2 * channels), node-major as TableFit writes them. Returns the basis of
// min(K, N^2 * channels) functions and writes each sample's weights to weights (samples x K, zero
// for functions beyond the rank). Its products run on up to `threads` threads; the result does not
// depend on how many.
Result<PcaBasis> fitPcaBasis(const std::vector<float>& tables, size_t samples, uint32_t tableSize, uint32_t channels,
                             uint32_t components, std::vector<float>& weights, uint32_t threads = 1);

// The weights of `samples` further tables on a basis fitted by fitPcaBasis (samples x K), on up to
// `threads` threads (the result does not depend on how many).
std::vector<float> projectOnBasis(const std::vector<float>& tables, size_t samples, const PcaBasis& basis,
                                  uint32_t threads = 1);

// ---- Clusters: one table per group of alike samples (docs/encodings.md, "Clusters") -------------
// A Pca field whose functions are the mean tables of K clusters of its samples and whose weights
// are one-hot: each sample decodes to its cluster's mean, whatever the others. Where the samples
// form a family whose jumps move from sample to sample (glass turned on a lathe: the torus, the
// glass of water), a sum of K shared components blends every jump's places into the reconstruction,
// while a cluster's mean blends only those of alike samples: it fits the nodes worse but renders
// better. Where the functions vary smoothly (the cube's faces), components are far better; the
// bake chooses by measurement.
inline constexpr uint32_t kClusterIterations = 40;

struct ClusteredBasis {
  std::vector<float> basis;      // field.h layout, as PcaBasis::basis
  std::vector<float> weights;    // samples x K, one-hot
  std::vector<uint32_t> cluster; // each sample's
};

// k-means of the samples on their Pca weights (fitPcaBasis's orthonormal weighted space, where a
// distance is the weighted tables' squared error within the span), seeded by k-means++ from a fixed
// sequence and iterated until no sample moves (at most kClusterIterations); an empty cluster is
// given the sample farthest from its own cluster's centre. tables: samples x functionSize, as for
// fitPcaBasis; pcaWeights: samples x pcaComponents; `seed` picks the seeding sequence (k-means
// finds a local optimum: another seed, other clusters). Deterministic whatever `threads`.
Result<ClusteredBasis> clusterTables(const std::vector<float>& tables, size_t samples, size_t functionSize,
                                     const std::vector<float>& pcaWeights, uint32_t pcaComponents, uint32_t clusters,
                                     uint64_t seed = 0, uint32_t threads = 1);

// ---- u8 refinement layers of a Pca field (docs/encodings.md, "Quantization") -------------------
// A u8 layer keeps 255 levels over its component's range over the whole field. The leading
// components carry most of every table and have the widest ranges, so their rounding is most of
// what u8 loses. A refinement layer is a copy of a leading component's basis function whose weight
// is what the u8 layer of that component lost: the two layers hold the weight to about 16 bits. It
// takes the place of the last component. The decoder does not know: it sums K layers as before.

// What dropping a trailing component costs is priced on the samples where its weights are
// smallest, this share of them: rounding errs on every sample alike, while a trailing component's
// weight is heavy-tailed: the typical sample hardly uses it, and a few edge samples would dominate
// a mean over all of them, refining too few layers (docs/encodings.md, "Quantization").
inline constexpr double kRefinementTypicalShare = 0.75;

// The components to refine, in the order of their refinement layers (which are the last
// refined.size() of `components`). Greedy on the weights (samples x components, fitPcaBasis's
// orthonormal weighted space, where a weight's error is the table's squared error): refine the
// component whose u8 rounding error (range / 255)^2 / 12 is largest while it exceeds what dropping
// the current last component costs (its squared weight summed over the kRefinementTypicalShare of
// samples where it is smallest, over all samples, less its own rounding error).
std::vector<uint32_t> chooseRefinedComponents(const std::vector<float>& weights, size_t samples, uint32_t components);

// Makes the last refined.size() functions of `basis` (field.h layout, functionSize values each)
// copies of the refined ones and zeroes their weights: the float encoding is then the truncation
// to components - refined.size() functions, and fillRefinementWeights adds what quantization loses.
void makeRefinementLayers(std::vector<float>& weights, size_t samples, uint32_t components, std::vector<float>& basis,
                          size_t functionSize, const std::vector<uint32_t>& refined);

// Each refinement layer's weight: its component's weight less `coarse(sample, component)`, the
// value the component's own layer decodes to after quantization.
void fillRefinementWeights(std::vector<float>& weights, size_t samples, uint32_t components,
                           const std::vector<uint32_t>& refined,
                           const std::function<float(size_t sample, uint32_t component)>& coarse);

// The refinement layers of a stored basis: for each trailing function that repeats an earlier one
// bit for bit, the component it refines (empty for a basis without refinement layers).
std::vector<uint32_t> refinedComponentsOf(const std::vector<float>& basis, uint32_t components, size_t functionSize);

}  // namespace shrefract::bake
