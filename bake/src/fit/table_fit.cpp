#include <shrefract/bake/table_fit.h>
#include <shrefract/field.h>
#include <shrefract/field_decode.h>

#include "parallel.h"
#include "splitmix.h"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <string>

namespace shrefract::bake {

namespace {

Result<void> checkTableSize(uint32_t n) {
  if (n < 2 || n > kMaxTableSize)
    return makeError(ErrorCode::InvalidArgument,
                     "table size " + std::to_string(n) + " is outside 2.." + std::to_string(kMaxTableSize));
  return {};
}

// Eigen's dense symmetric solver is O(dim^3) on one core: seconds at 16x16 tables (dim up to
// 1024), over a minute at 32x32 (4096). Above this size the leading eigenvectors come from a
// subspace iteration instead, which costs a few products of the Gram matrix with a thin block.
constexpr Eigen::Index kExactEigenDim = 1024;
constexpr Eigen::Index kEigenOversampling = 64;  // block columns beyond the k wanted
constexpr int kEigenPowerIterations = 6;

// The k leading eigenvectors of the symmetric `m` (its lower triangle is read) by Eigen's dense
// solver, as columns in descending order of eigenvalue.
Result<Eigen::MatrixXd> exactLeadingEigenvectors(const Eigen::MatrixXd& m, Eigen::Index k) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(m);
  if (eigen.info() != Eigen::Success) return makeError(ErrorCode::Unsupported, "pca: the eigen solver did not converge");
  // Eigenvalues ascend: the leading vectors are the last columns.
  return Eigen::MatrixXd(eigen.eigenvectors().rightCols(std::min(k, m.rows())).rowwise().reverse());
}

// The fit's large products run in fixed blocks, one block per task: a block's product is the same
// whatever the threads, so the basis does not depend on them. 32x32 tables with five channels make
// the Gram matrix 5120 x 5120; on one thread its product and the subspace iteration took most of a
// 20000-sample bake.
constexpr Eigen::Index kProductColumns = 128;
// Products also split their rows, in fixed blocks of this many: the subspace iteration's thin
// block (k + 64 = 388 columns) alone gave 4 column blocks, 128 + 128 + 128 + 4, and two threads
// one 256 columns and the other 132; k-means (assignToCentres) takes its samples this many at a
// time. Splitting the rows does not split the depth of any output's sum: the cube's, torus's and a
// 32x32 sphere's fields, and the clusters, came out byte-identical but for their timings
// (docs/performance.md).
constexpr Eigen::Index kProductRows = 2048;

template <class Matrix>
Eigen::Index columnBlocks(const Matrix& m) {
  return (m.cols() + kProductColumns - 1) / kProductColumns;
}

template <class Matrix>
Eigen::Index rowBlocks(const Matrix& m) {
  return (m.rows() + kProductRows - 1) / kProductRows;
}

// lhs * rhs in blocks of kProductRows rows by kProductColumns columns, in parallel.
template <class Lhs, class Rhs>
Rhs productInBlocks(const Lhs& lhs, const Rhs& rhs, uint32_t threads) {
  Rhs out(lhs.rows(), rhs.cols());
  const Eigen::Index rows = rowBlocks(lhs);
  parallelFor(size_t(rows * columnBlocks(rhs)), threads, [&](size_t task) {
    const Eigen::Index i = Eigen::Index(task) % rows * kProductRows, h = std::min(kProductRows, lhs.rows() - i);
    const Eigen::Index j = Eigen::Index(task) / rows * kProductColumns, w = std::min(kProductColumns, rhs.cols() - j);
    out.block(i, j, h, w).noalias() = lhs.middleRows(i, h) * rhs.middleCols(j, w);
  });
  return out;
}

// x^T x, both triangles: each column block's part on and below the diagonal in parallel, then
// mirrored (half the products of the full square).
Eigen::MatrixXd gramOf(const Eigen::MatrixXf& x, uint32_t threads) {
  const Eigen::Index dim = x.cols();
  Eigen::MatrixXf lower = Eigen::MatrixXf::Zero(dim, dim);
  parallelFor(size_t(columnBlocks(x)), threads, [&](size_t b) {
    const Eigen::Index j = Eigen::Index(b) * kProductColumns, w = std::min(kProductColumns, dim - j);
    lower.block(j, j, dim - j, w).noalias() = x.rightCols(dim - j).transpose() * x.middleCols(j, w);
  });
  Eigen::MatrixXd gram = lower.cast<double>();
  for (Eigen::Index c = 1; c < dim; ++c) gram.col(c).head(c) = gram.row(c).head(c).transpose();  // mirror
  return gram;
}

// The k leading eigenvectors of a positive semi-definite n x n matrix that `product` multiplies
// thin blocks by: randomized subspace iteration (Halko, Martinsson and Tropp 2011, algorithms 4.4
// and 5.3): a block of k + 64 vectors, multiplied by the matrix and re-orthonormalized
// kEigenPowerIterations times, then the exact solver on the matrix projected onto the block. The
// start block is a fixed sequence, so the bake stays deterministic.
template <class Product>
Result<Eigen::MatrixXd> subspaceIteration(Eigen::Index n, Eigen::Index k, const Product& product) {
  const Eigen::Index block = std::min(n, k + kEigenOversampling);
  Eigen::MatrixXd q(n, block);
  uint64_t state = 0;
  for (Eigen::Index j = 0; j < block; ++j)
    for (Eigen::Index i = 0; i < n; ++i) q(i, j) = double(splitmix(state) >> 11) * 0x1p-53 - 0.5;
  for (int it = 0; it < kEigenPowerIterations; ++it) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(product(q));
    q = qr.householderQ() * Eigen::MatrixXd::Identity(n, block);
  }
  const Eigen::MatrixXd projected = q.transpose() * product(q);
  auto small = exactLeadingEigenvectors(projected, k);
  if (!small) return small.error();
  return Eigen::MatrixXd(q * small.value());
}

// The same for `gram`, both triangles stored (gramOf): the subspace iteration for large matrices;
// fields of tables up to kExactEigenDim values use the exact solver.
Result<Eigen::MatrixXd> leadingEigenvectors(const Eigen::MatrixXd& gram, Eigen::Index k, uint32_t threads) {
  const Eigen::Index n = gram.rows();
  if (n <= kExactEigenDim || 2 * std::min(n, k + kEigenOversampling) >= n) return exactLeadingEigenvectors(gram, k);
  return subspaceIteration(n, k, [&](const Eigen::MatrixXd& q) { return productInBlocks(gram, q, threads); });
}

// Tables of more than this many values skip the Gram matrix: at 64x64 with 5 channels it holds
// 20480^2 values (3.4 GB in double, beside the float lower triangle it is mirrored from), and
// forming it costs samples x dim^2 / 2 products. The leading right singular vectors of x come
// instead from the same subspace iteration applied to x^T x as two thin products with x, never
// formed. 32x32 tables (up to 5120 values) keep the Gram path, so their fields do not change.
constexpr Eigen::Index kGramMaxDim = 8192;

// The k leading eigenvectors of x^T x (the right singular vectors of x) without forming it; each
// product x^T (x q) in fixed blocks (deterministic).
Result<Eigen::MatrixXd> leadingRightSingularVectors(const Eigen::MatrixXf& x, Eigen::Index k, uint32_t threads) {
  return subspaceIteration(x.cols(), k, [&](const Eigen::MatrixXd& q) {
    const Eigen::MatrixXf y = productInBlocks(x, Eigen::MatrixXf(q.cast<float>()), threads);
    return Eigen::MatrixXd(productInBlocks(x.transpose(), y, threads).cast<double>());
  });
}

}  // namespace

glm::dvec3 nodeDirection(float x, float y, uint32_t n) {
  const std::array<float, 3> d = hemiOctDirectionAt(x, y, n);
  glm::dvec3 w(d[0], d[1], d[2]);
  if (w.z < kNodeMinZ) {
    const double tangential = std::sqrt((1.0 - kNodeMinZ * kNodeMinZ) / (w.x * w.x + w.y * w.y));
    w = glm::dvec3(w.x * tangential, w.y * tangential, kNodeMinZ);
  }
  return w;
}

DirectionGrid makeNodeGrid(uint32_t n) {
  DirectionGrid g;
  g.rows = g.columns = n;
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      g.directions.push_back(nodeDirection(float(i), float(j), n));
      g.weights.push_back(2.0 * std::numbers::pi / (double(n) * n));
    }
  return g;
}

Result<TableFit> TableFit::atNodes(uint32_t n) {
  if (auto ok = checkTableSize(n); !ok) return ok.error();
  TableFit fit;
  fit.n_ = n;
  fit.identity_ = true;
  return fit;
}

Result<TableFit> TableFit::create(const DirectionGrid& grid, uint32_t n, double lambda) {
  if (auto ok = checkTableSize(n); !ok) return ok.error();
  if (grid.directions.empty()) return makeError(ErrorCode::InvalidArgument, "empty direction grid");
  if (!(lambda > 0.0) || !std::isfinite(lambda))
    return makeError(ErrorCode::InvalidArgument, "table regularization must be finite and > 0");
  TableFit fit;
  fit.n_ = n;
  const uint32_t nodes = n * n;
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(nodes, nodes);
  double totalWeight = 0.0;
  for (size_t d = 0; d < grid.directions.size(); ++d) {
    const glm::dvec3 w = grid.directions[d];
    const HemiOctBilinear b = hemiOctBilinear(float(w.x), float(w.y), float(w.z), n);
    totalWeight += grid.weights[d];
    for (int i = 0; i < 4; ++i) {
      fit.gridNodes_.push_back(b.node[i]);
      fit.gridWeights_.push_back(static_cast<float>(grid.weights[d] * double(b.weight[i])));
      for (int j = 0; j < 4; ++j) normal(b.node[i], b.node[j]) += grid.weights[d] * double(b.weight[i]) * double(b.weight[j]);
    }
  }
  // Neighbour differences (a graph Laplacian over the 4-neighbourhood), scaled to a node's share
  // of the solid angle so that lambda means the same at every N.
  const double penalty = lambda * totalWeight / nodes;
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i)
      for (const auto& [di, dj] : {std::pair{1u, 0u}, std::pair{0u, 1u}}) {
        if (i + di >= n || j + dj >= n) continue;
        const uint32_t a = j * n + i, b = (j + dj) * n + i + di;
        normal(a, a) += penalty;
        normal(b, b) += penalty;
        normal(a, b) -= penalty;
        normal(b, a) -= penalty;
      }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
  if (ldlt.info() != Eigen::Success)
    return makeError(ErrorCode::InvalidArgument, "table fit: the normal equations are singular for table size " +
                                                     std::to_string(n));
  const Eigen::MatrixXd inverse = ldlt.solve(Eigen::MatrixXd::Identity(nodes, nodes));
  fit.inverse_.resize(size_t(nodes) * nodes);
  for (uint32_t r = 0; r < nodes; ++r)
    for (uint32_t c = 0; c < nodes; ++c) fit.inverse_[size_t(r) * nodes + c] = static_cast<float>(inverse(r, c));
  return fit;
}

void TableFit::fit(const float* values, uint32_t channels, float* out) const {
  // The right-hand side A^T W f touches 4 nodes per direction; then one product with the inverse.
  const uint32_t nodes = nodeCount();
  if (identity_) {
    std::copy(values, values + size_t(nodes) * channels, out);
    return;
  }
  thread_local std::vector<float> rhs;
  rhs.assign(size_t(nodes) * channels, 0.0f);
  const size_t directions = gridNodes_.size() / 4;
  for (size_t d = 0; d < directions; ++d)
    for (int i = 0; i < 4; ++i) {
      const float w = gridWeights_[4 * d + i];
      float* r = &rhs[size_t(gridNodes_[4 * d + i]) * channels];
      for (uint32_t c = 0; c < channels; ++c) r[c] += w * values[d * channels + c];
    }
  std::fill(out, out + size_t(nodes) * channels, 0.0f);
  for (uint32_t a = 0; a < nodes; ++a) {
    const float* row = &inverse_[size_t(a) * nodes];
    float* o = &out[size_t(a) * channels];
    for (uint32_t b = 0; b < nodes; ++b)
      for (uint32_t c = 0; c < channels; ++c) o[c] += row[b] * rhs[size_t(b) * channels + c];
  }
}

Result<PcaBasis> fitPcaBasis(const std::vector<float>& tables, size_t samples, uint32_t tableSize, uint32_t channels,
                             uint32_t components, std::vector<float>& weights, uint32_t threads) {
  const size_t dim = size_t(tableSize) * tableSize * channels;
  if (samples == 0 || tables.size() != samples * dim || components == 0)
    return makeError(ErrorCode::InvalidArgument, "pca: no samples or mismatched table sizes");
  // Channel weights: x, y, z as they are; tau, when its RMS is above 1, scaled down to unit RMS so
  // that long optical depths do not take the functions the angular error needs.
  std::vector<double> scale(channels, 1.0);
  for (uint32_t c = 3; c < channels; ++c) {
    double sum = 0.0;
    for (size_t i = c; i < tables.size(); i += channels) sum += double(tables[i]) * double(tables[i]);
    const double rms = std::sqrt(sum / double(tables.size() / channels));
    scale[c] = 1.0 / std::max(rms, 1.0);
  }
  Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> raw(tables.data(),
                                                                                              Eigen::Index(samples),
                                                                                              Eigen::Index(dim));
  Eigen::VectorXf columnScale(dim);
  for (size_t i = 0; i < dim; ++i) {
    const uint32_t node = static_cast<uint32_t>(i / channels);
    const std::array<float, 3> d = hemiOctDirection(node % tableSize, node / tableSize, tableSize);
    const double nodeWeight = std::sqrt(std::max(double(d[2]), kPcaMinNodeCosine));
    columnScale[Eigen::Index(i)] = static_cast<float>(scale[i % channels] * nodeWeight);
  }
  const Eigen::MatrixXf x = raw * columnScale.asDiagonal();
  const uint32_t k = static_cast<uint32_t>(std::min<size_t>(components, dim));
  auto leading = Eigen::Index(dim) > kGramMaxDim ? leadingRightSingularVectors(x, Eigen::Index(k), threads)
                                                 : leadingEigenvectors(gramOf(x, threads), Eigen::Index(k), threads);
  if (!leading) return leading.error();
  Eigen::MatrixXf basis = Eigen::MatrixXf::Zero(Eigen::Index(dim), Eigen::Index(components));
  for (uint32_t j = 0; j < k; ++j) basis.col(Eigen::Index(j)) = leading.value().col(Eigen::Index(j)).cast<float>();
  const Eigen::MatrixXf w = productInBlocks(x, basis, threads);  // samples x components
  weights.resize(samples * components);
  for (size_t s = 0; s < samples; ++s)
    for (uint32_t j = 0; j < components; ++j) weights[s * components + j] = w(Eigen::Index(s), Eigen::Index(j));
  PcaBasis out;
  out.components = components;
  out.tableSize = tableSize;
  out.channels = channels;
  out.scale.assign(columnScale.data(), columnScale.data() + dim);
  out.basis.resize(size_t(components) * dim);
  for (uint32_t j = 0; j < components; ++j)
    for (size_t i = 0; i < dim; ++i)  // undo the weights: decoded values are in the data's units
      out.basis[size_t(j) * dim + i] = basis(Eigen::Index(i), Eigen::Index(j)) / columnScale[Eigen::Index(i)];
  return out;
}

std::vector<float> projectOnBasis(const std::vector<float>& tables, size_t samples, const PcaBasis& basis,
                                  uint32_t threads) {
  // The stored basis is in the data's units (B = D^-1 B_scaled), so the projection on the
  // orthonormal B_scaled of the weighted table D t is w = B_scaled^T D t = (D^2 B)^T t.
  const size_t dim = size_t(basis.tableSize) * basis.tableSize * basis.channels;
  std::vector<double> scale2(dim);
  for (size_t i = 0; i < dim; ++i) scale2[i] = double(basis.scale[i]) * double(basis.scale[i]);
  std::vector<float> out(samples * basis.components, 0.0f);
  parallelFor(samples, threads, [&](size_t s) {
    for (uint32_t k = 0; k < basis.components; ++k) {
      double w = 0.0;
      const float* b = &basis.basis[k * dim];
      const float* t = &tables[s * dim];
      for (size_t i = 0; i < dim; ++i) w += scale2[i] * double(b[i]) * double(t[i]);
      out[s * basis.components + k] = static_cast<float>(w);
    }
  });
  return out;
}

namespace {

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// k-means++ seeds: the first centre drawn uniformly, each next one with probability proportional to
// the squared distance to the nearest centre so far.
RowMatrix seedCentres(const RowMatrix& w, uint32_t clusters, uint64_t seed) {
  const Eigen::Index n = w.rows();
  uint64_t state = 0x434c5553ull + seed;
  auto uniform = [&] { return double(splitmix(state) >> 11) * 0x1.0p-53; };
  RowMatrix c(Eigen::Index(clusters), w.cols());
  std::vector<double> nearest(size_t(n), std::numeric_limits<double>::max());
  c.row(0) = w.row(std::min<Eigen::Index>(n - 1, Eigen::Index(uniform() * double(n))));
  for (Eigen::Index j = 1; j < c.rows(); ++j) {
    double total = 0.0;
    for (Eigen::Index s = 0; s < n; ++s) {
      nearest[size_t(s)] = std::min(nearest[size_t(s)], double((w.row(s) - c.row(j - 1)).squaredNorm()));
      total += nearest[size_t(s)];
    }
    double r = uniform() * total;
    Eigen::Index pick = n - 1;
    for (Eigen::Index s = 0; s < n && pick == n - 1; ++s)
      if ((r -= nearest[size_t(s)]) <= 0.0) pick = s;
    c.row(j) = w.row(pick);
  }
  return c;
}

// Each sample's nearest centre; returns how many samples changed cluster. `distance` receives
// each sample's squared distance to it. The samples-by-centres products run kProductRows samples
// at a time on the bake's threads, never the whole matrix (44240 x 4096 floats for the bunny with
// --clusters 4096).
size_t assignToCentres(const RowMatrix& w, const RowMatrix& c, std::vector<uint32_t>& cluster,
                       std::vector<double>& distance, uint32_t threads) {
  const Eigen::VectorXf cn = c.rowwise().squaredNorm();
  const size_t chunks = size_t(rowBlocks(w));
  std::vector<size_t> moved(chunks, 0);
  parallelFor(chunks, threads, [&](size_t chunk) {
    const Eigen::Index first = Eigen::Index(chunk) * kProductRows;
    const Eigen::Index rows = std::min(kProductRows, w.rows() - first);
    const Eigen::MatrixXf dots = w.middleRows(first, rows) * c.transpose();
    for (Eigen::Index r = 0; r < rows; ++r) {
      const size_t s = size_t(first + r);
      Eigen::Index best = 0;
      (cn.transpose() - 2.0f * dots.row(r)).minCoeff(&best);
      distance[s] = double((w.row(Eigen::Index(s)) - c.row(best)).squaredNorm());
      if (cluster[s] != uint32_t(best)) {
        ++moved[chunk];
        cluster[s] = uint32_t(best);
      }
    }
  });
  size_t total = 0;
  for (size_t m : moved) total += m;
  return total;
}

// The centres of the clusters; an empty one takes the sample farthest from its centre.
void updateCentres(const RowMatrix& w, const std::vector<uint32_t>& cluster, std::vector<double>& distance,
                   RowMatrix& c) {
  std::vector<size_t> count(size_t(c.rows()), 0);
  c.setZero();
  for (Eigen::Index s = 0; s < w.rows(); ++s) {
    c.row(cluster[size_t(s)]) += w.row(s);
    ++count[cluster[size_t(s)]];
  }
  for (Eigen::Index j = 0; j < c.rows(); ++j) {
    if (count[size_t(j)] > 0) {
      c.row(j) /= float(count[size_t(j)]);
      continue;
    }
    const auto far = size_t(std::max_element(distance.begin(), distance.end()) - distance.begin());
    c.row(j) = w.row(Eigen::Index(far));
    distance[far] = 0.0;
  }
}

// What dropping a component costs: the sum of its squared weights over the kRefinementTypicalShare
// of samples where they are smallest, over all samples (`squares` is reordered).
double typicalEnergy(std::vector<double>& squares) {
  const size_t typical = static_cast<size_t>(double(squares.size()) * kRefinementTypicalShare);
  std::nth_element(squares.begin(), squares.begin() + typical, squares.end());
  double sum = 0.0;
  for (size_t i = 0; i < typical; ++i) sum += squares[i];
  return sum / double(squares.size());
}

}  // namespace

Result<ClusteredBasis> clusterTables(const std::vector<float>& tables, size_t samples, size_t functionSize,
                                     const std::vector<float>& pcaWeights, uint32_t pcaComponents, uint32_t clusters,
                                     uint64_t seed, uint32_t threads) {
  if (samples < clusters || clusters == 0 || tables.size() != samples * functionSize ||
      pcaWeights.size() != samples * pcaComponents)
    return makeError(ErrorCode::InvalidArgument, "clusters: fewer samples than clusters or mismatched sizes");
  const Eigen::Map<const RowMatrix> w(pcaWeights.data(), Eigen::Index(samples), Eigen::Index(pcaComponents));
  RowMatrix c = seedCentres(w, clusters, seed);
  ClusteredBasis out;
  out.cluster.assign(samples, clusters);  // none yet: every sample moves on the first pass
  std::vector<double> distance(samples);
  bool settled = false;
  for (uint32_t i = 0; i < kClusterIterations && !settled; ++i) {
    settled = assignToCentres(w, c, out.cluster, distance, threads) == 0;
    if (!settled) updateCentres(w, out.cluster, distance, c);
  }
  if (!settled) assignToCentres(w, c, out.cluster, distance, threads);  // the last centres moved: assign to them
  // Each function: its cluster's mean table (in the data's units; an empty cluster's stays zero).
  std::vector<size_t> count(clusters, 0);
  for (uint32_t k : out.cluster) ++count[k];
  out.basis.assign(size_t(clusters) * functionSize, 0.0f);
  parallelFor(clusters, threads, [&](size_t k) {
    std::vector<double> sum(functionSize, 0.0);
    for (size_t s = 0; s < samples; ++s)
      if (out.cluster[s] == k)
        for (size_t i = 0; i < functionSize; ++i) sum[i] += double(tables[s * functionSize + i]);
    for (size_t i = 0; i < functionSize && count[k] > 0; ++i)
      out.basis[k * functionSize + i] = static_cast<float>(sum[i] / double(count[k]));
  });
  out.weights.assign(samples * clusters, 0.0f);
  for (size_t s = 0; s < samples; ++s) out.weights[s * clusters + out.cluster[s]] = 1.0f;
  return out;
}

std::vector<uint32_t> chooseRefinedComponents(const std::vector<float>& weights, size_t samples, uint32_t components) {
  if (samples == 0 || components < 2 || weights.size() != samples * components) return {};
  std::vector<double> rounding(components), energy(components), squares(samples);
  for (uint32_t k = 0; k < components; ++k) {
    float lo = weights[k], hi = weights[k];
    for (size_t s = 0; s < samples; ++s) {
      const float w = weights[s * components + k];
      lo = std::min(lo, w);
      hi = std::max(hi, w);
      squares[s] = double(w) * double(w);
    }
    const double step = (double(hi) - double(lo)) / 255.0;
    rounding[k] = step * step / 12.0;
    energy[k] = typicalEnergy(squares);
  }
  std::vector<uint32_t> refined;
  std::vector<bool> taken(components, false);
  for (uint32_t last = components - 1; last > 0; --last) {  // `last`: the function a refinement replaces
    uint32_t worst = last;
    for (uint32_t k = 0; k < last; ++k)
      if (!taken[k] && (worst == last || rounding[k] > rounding[worst])) worst = k;
    // A refinement layer rounds the residual to 1/255 of the step, leaving rounding / 255^2.
    const double gain = rounding[worst] * (1.0 - 1.0 / (255.0 * 255.0)), cost = energy[last] - rounding[last];
    if (worst == last || taken[last] || !(gain > cost)) break;
    taken[worst] = true;
    refined.push_back(worst);
  }
  return refined;
}

void makeRefinementLayers(std::vector<float>& weights, size_t samples, uint32_t components, std::vector<float>& basis,
                          size_t functionSize, const std::vector<uint32_t>& refined) {
  const uint32_t first = components - static_cast<uint32_t>(refined.size());
  for (size_t i = 0; i < refined.size(); ++i) {
    const uint32_t layer = first + static_cast<uint32_t>(i);
    std::copy_n(&basis[refined[i] * functionSize], functionSize, &basis[layer * functionSize]);
    for (size_t s = 0; s < samples; ++s) weights[s * components + layer] = 0.0f;
  }
}

void fillRefinementWeights(std::vector<float>& weights, size_t samples, uint32_t components,
                           const std::vector<uint32_t>& refined,
                           const std::function<float(size_t sample, uint32_t component)>& coarse) {
  const uint32_t first = components - static_cast<uint32_t>(refined.size());
  for (size_t s = 0; s < samples; ++s)
    for (size_t i = 0; i < refined.size(); ++i) {
      const uint32_t k = refined[i];
      weights[s * components + first + i] = weights[s * components + k] - coarse(s, k);
    }
}

std::vector<uint32_t> refinedComponentsOf(const std::vector<float>& basis, uint32_t components, size_t functionSize) {
  if (functionSize == 0 || basis.size() != size_t(components) * functionSize) return {};
  auto same = [&](uint32_t a, uint32_t b) {
    return std::memcmp(&basis[a * functionSize], &basis[b * functionSize], functionSize * sizeof(float)) == 0;
  };
  std::vector<uint32_t> refined;  // collected from the last layer back
  for (uint32_t layer = components; layer-- > 1;) {
    uint32_t k = 0;
    while (k < layer && !same(k, layer)) ++k;
    if (k == layer) break;
    refined.push_back(k);
  }
  std::reverse(refined.begin(), refined.end());
  return refined;
}

}  // namespace shrefract::bake
