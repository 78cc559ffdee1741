// The Pca encoding's own parts: the basis of large tables (subspace iteration), clusters and the
// u8 refinement layers, each against its closed form or the float functions it stands for.
#include "bake/encoding_support.h"

namespace shrefract::bake {
namespace {

using namespace encoding_test;

// --- the Pca basis of large tables (table_fit.cpp: subspace iteration above 1024 values) -------

// Orthonormalizes the columns of a (rows x cols, column-major) in place (modified Gram-Schmidt).
void orthonormalizeColumns(std::vector<double>& a, size_t rows, size_t cols) {
  for (size_t j = 0; j < cols; ++j) {
    double* v = &a[j * rows];
    for (size_t p = 0; p < j; ++p) {
      const double* u = &a[p * rows];
      double dot = 0.0;
      for (size_t i = 0; i < rows; ++i) dot += u[i] * v[i];
      for (size_t i = 0; i < rows; ++i) v[i] -= dot * u[i];
    }
    double norm = 0.0;
    for (size_t i = 0; i < rows; ++i) norm += v[i] * v[i];
    for (size_t i = 0; i < rows; ++i) v[i] /= std::sqrt(norm);
  }
}

// Tables of a known spectrum: in the basis's weighted space (values times the weights D it
// reports) they are C diag(a) U^T with C and U orthonormal, so the best K functions leave exactly
// the sum of a_j^2 beyond K. 19x19 tables of 3 channels are 1083 values, above the size where the
// exact solver is used; 53x53 tables are 8427, above the size where the Gram matrix is formed
// (table_fit.cpp kGramMaxDim: the iteration runs on the tables themselves, and its products with
// the transposed tables split their 8427 rows into blocks of 2048, the last one partial: a block
// left out fails both sizes). The spectrum decays
// slowly (a_j = 0.95^j), so the block must converge.
void expectOptimalEnergy(uint32_t kN) {
  constexpr uint32_t kChannels = 3, kComponents = 40;
  const size_t kDim = size_t(kN) * kN * kChannels, kSamples = 300, kRank = 150;
  Random rng{11};
  std::vector<float> weights;
  // D depends only on the nodes (and on tau's RMS, absent here): take it from any fit.
  std::vector<float> probe(kSamples * kDim);
  for (float& v : probe) v = float(rng.next());
  auto first = fitPcaBasis(probe, kSamples, kN, kChannels, 4, weights);
  ASSERT_TRUE(first.ok()) << first.error().message;
  const std::vector<float> d = first.value().scale;

  std::vector<double> u(kDim * kRank), c(kSamples * kRank), a(kRank);
  for (double& v : u) v = rng.next() - 0.5;
  for (double& v : c) v = rng.next() - 0.5;
  orthonormalizeColumns(u, kDim, kRank);
  orthonormalizeColumns(c, kSamples, kRank);
  double optimal = 0.0, total = 0.0;
  for (size_t j = 0; j < kRank; ++j) {
    a[j] = 100.0 * std::pow(0.95, double(j));
    total += a[j] * a[j];
    if (j >= kComponents) optimal += a[j] * a[j];
  }
  std::vector<double> x(kSamples * kDim, 0.0);  // weighted tables, sample-major
  for (size_t s = 0; s < kSamples; ++s)
    for (size_t j = 0; j < kRank; ++j)
      for (size_t i = 0; i < kDim; ++i) x[s * kDim + i] += c[j * kSamples + s] * a[j] * u[j * kDim + i];
  std::vector<float> tables(kSamples * kDim);
  for (size_t k = 0; k < tables.size(); ++k) tables[k] = float(x[k] / double(d[k % kDim]));

  auto fitted = fitPcaBasis(tables, kSamples, kN, kChannels, kComponents, weights);
  ASSERT_TRUE(fitted.ok()) << fitted.error().message;
  const PcaBasis& basis = fitted.value();
  double residual = 0.0;
  for (size_t s = 0; s < kSamples; ++s)
    for (size_t i = 0; i < kDim; ++i) {
      double r = x[s * kDim + i];
      for (size_t k = 0; k < kComponents; ++k)
        r -= double(weights[s * kComponents + k]) * double(basis.basis[k * kDim + i]) * double(d[i]);
      residual += r * r;
    }
  // float tables and basis: about 1e-7 of the total energy on top of the optimum.
  EXPECT_LE(residual, optimal * 1.01 + total * 1e-6) << "optimal " << optimal << " of " << total;
  EXPECT_GE(residual, optimal * 0.99 - total * 1e-6);
}

TEST(PcaBasis, LargeTablesKeepTheOptimalEnergy) { expectOptimalEnergy(19); }
TEST(PcaBasis, TablesBeyondTheGramMatrixKeepTheOptimalEnergy) { expectOptimalEnergy(53); }

// --- Clusters (table_fit.h) --------------------------------------------------------------------

// 5000 samples drawn around 6 centres (8x8 tables of 3 channels; centres uniform in [-0.5, 0.5],
// about 4 apart, noise 0.05 wide, about 0.2): clusterTables, given 6 clusters and the samples'
// weights on 16 components, must put each group in a cluster of its own, give every sample one-hot
// weights and make each function its cluster's mean table, on 1 thread as on 3. 5000 samples are
// two of the assignment's chunks of 2048 and part of a third.
TEST(Clusters, AlikeSamplesShareTheirGroupsMeanTable) {
  constexpr uint32_t kN = 8, kChannels = 3, kGroups = 6, kComponents = 16;
  constexpr size_t kDim = size_t(kN) * kN * kChannels, kSamples = 5000;
  Random rng{5};
  std::vector<float> centres(kGroups * kDim), tables(kSamples * kDim);
  for (float& v : centres) v = float(rng.next() - 0.5);
  std::vector<uint32_t> group(kSamples);
  for (size_t s = 0; s < kSamples; ++s) {
    group[s] = uint32_t(rng.next() * kGroups) % kGroups;
    for (size_t i = 0; i < kDim; ++i)
      tables[s * kDim + i] = centres[group[s] * kDim + i] + float(0.05 * (rng.next() - 0.5));
  }
  std::vector<float> weights;
  ASSERT_TRUE(fitPcaBasis(tables, kSamples, kN, kChannels, kComponents, weights).ok());
  auto one = clusterTables(tables, kSamples, kDim, weights, kComponents, kGroups, 0, 1);
  auto three = clusterTables(tables, kSamples, kDim, weights, kComponents, kGroups, 0, 3);
  ASSERT_TRUE(one.ok() && three.ok());
  EXPECT_EQ(one->cluster, three->cluster);
  EXPECT_EQ(one->basis, three->basis);
  std::map<uint32_t, uint32_t> clusterOfGroup, groupOfCluster;
  for (size_t s = 0; s < kSamples; ++s) {
    const uint32_t k = one->cluster[s];
    EXPECT_EQ(clusterOfGroup.emplace(group[s], k).first->second, k) << "a group split, sample " << s;
    EXPECT_EQ(groupOfCluster.emplace(k, group[s]).first->second, group[s]) << "groups merged, sample " << s;
    for (uint32_t j = 0; j < kGroups; ++j) EXPECT_EQ(one->weights[s * kGroups + j], j == k ? 1.0f : 0.0f);
  }
  EXPECT_EQ(clusterOfGroup.size(), size_t(kGroups));
  double worst = 0.0;
  for (uint32_t k = 0; k < kGroups; ++k)
    for (size_t i = 0; i < kDim; ++i) {
      double sum = 0.0;
      size_t members = 0;
      for (size_t s = 0; s < kSamples; ++s)
        if (one->cluster[s] == k) sum += double(tables[s * kDim + i]), ++members;
      worst = std::max(worst, std::abs(sum / double(members) - double(one->basis[k * kDim + i])));
    }
  EXPECT_LT(worst, 1e-6) << "a function is not its cluster's mean table";
  EXPECT_FALSE(clusterTables(tables, 5, kDim, weights, kComponents, kGroups).ok()) << "fewer samples than clusters";
}

// --- u8 refinement layers of Pca (table_fit.h) --------------------------------------------------

TEST(PcaRefinement, TheWidestComponentsAreRefinedInPlaceOfTheWeakest) {
  constexpr size_t kSamples = 1000;
  constexpr uint32_t kComponents = 6;
  Random rng{7};
  std::vector<float> weights(kSamples * kComponents);
  for (size_t s = 0; s < kSamples; ++s) {
    weights[s * kComponents + 0] = float(200.0 * rng.next() - 100.0);  // u8 rounding (200/255)^2/12 = 0.051
    weights[s * kComponents + 1] = float(2.0 * rng.next() - 1.0);      // 5.1e-6
    for (uint32_t k = 2; k < kComponents; ++k) weights[s * kComponents + k] = float(1e-4 * (rng.next() - 0.5));
  }
  // Dropping component 5, then 4, costs ~1e-9 each: both wide components are worth a layer; then
  // component 2's rounding (~1e-14) is worth less than component 3's energy.
  EXPECT_EQ(chooseRefinedComponents(weights, kSamples, kComponents), (std::vector<uint32_t>{0, 1}));
  // With every component carrying as much as the widest, dropping one costs more than it saves.
  std::vector<float> even(kSamples * kComponents);
  for (float& w : even) w = float(200.0 * rng.next() - 100.0);
  EXPECT_TRUE(chooseRefinedComponents(even, kSamples, kComponents).empty());
  EXPECT_TRUE(chooseRefinedComponents(weights, kSamples, 1).empty());

  constexpr size_t kFunction = 8;
  std::vector<float> basis(kComponents * kFunction);
  for (size_t i = 0; i < basis.size(); ++i) basis[i] = float(i) * 0.25f;
  const std::vector<uint32_t> refined = {0, 1};
  std::vector<float> w = weights;
  makeRefinementLayers(w, kSamples, kComponents, basis, kFunction, refined);
  EXPECT_EQ(refinedComponentsOf(basis, kComponents, kFunction), refined);
  for (size_t s = 0; s < kSamples; ++s) EXPECT_EQ(w[s * kComponents + 4] + w[s * kComponents + 5], 0.0f);
  // The coarse value of a component plus its refinement weight is the weight again.
  auto coarse = [&](size_t s, uint32_t k) { return std::round(w[s * kComponents + k]); };
  fillRefinementWeights(w, kSamples, kComponents, refined, coarse);
  for (size_t s = 0; s < kSamples; ++s)
    for (size_t i = 0; i < refined.size(); ++i) {
      const uint32_t k = refined[i];
      EXPECT_NEAR(coarse(s, k) + w[s * kComponents + 4 + i], weights[s * kComponents + k], 1e-5f);
    }
}

// A trailing component carried by 5 % of the samples (weight +-10 there, 1e-4 elsewhere): its mean
// squared weight (5) is far above the widest component's rounding ((200/255)^2/12 = 0.051), but
// on the typical samples (kRefinementTypicalShare, inside the 95 % that hardly use it) dropping it
// costs ~1e-9, so the widest component is refined in its place. Priced on the mean, nothing is.
TEST(PcaRefinement, ATrailingComponentIsPricedOnItsTypicalSamples) {
  constexpr size_t kSamples = 1000;
  constexpr uint32_t kComponents = 3;
  static_assert(kRefinementTypicalShare <= 0.95);
  Random rng{13};
  std::vector<float> weights(kSamples * kComponents);
  for (size_t s = 0; s < kSamples; ++s) {
    weights[s * kComponents + 0] = float(200.0 * rng.next() - 100.0);
    weights[s * kComponents + 1] = float(100.0 * rng.next() - 50.0);
    weights[s * kComponents + 2] = s % 20 == 0 ? (s % 40 == 0 ? 10.0f : -10.0f) : float(1e-4 * (rng.next() - 0.5));
  }
  EXPECT_EQ(chooseRefinedComponents(weights, kSamples, kComponents), (std::vector<uint32_t>{0}));
}

// The same field without its refinement layers: the first K - M layers are a prefix of the
// layer-major coefficients, quantized with the codes a u8 field of K - M components has.
Field withoutRefinement(Field field, uint32_t refinements) {
  const size_t functionSize = size_t(field.tableSize) * field.tableSize * field.channels;
  field.components -= refinements;
  field.settings.components = field.components;
  field.coefficientsU8.resize(size_t(field.components) * field.texelCount());
  field.scale.resize(field.components);
  field.bias.resize(field.components);
  field.basis.resize(size_t(field.components) * functionSize);
  return field;
}

TEST(PcaRefinement, U8SphereDecodesCloseToTheFloatFunctions) {
  const Scene scene = builtin("sphere", 3);
  constexpr uint64_t kBudget = 700;
  BakeSettings settings = atNodes(settingsFor(Encoding::Pca, 64));
  settings.sampleBudget = kBudget;
  // Exits in object space: in the sample's frame every sample of the sphere stores nearly the same
  // function, the leading weights span narrow ranges and nothing is worth refining.
  settings.exitFrame = ExitFrame::Object;
  const Field u8 = bake(scene, settings, "builtin:sphere");
  ASSERT_TRUE(validateField(u8).ok());
  const std::vector<uint32_t> refined =
      refinedComponentsOf(u8.basis, u8.components, size_t(u8.tableSize) * u8.tableSize * u8.channels);
  ASSERT_FALSE(refined.empty());
  const uint32_t m = static_cast<uint32_t>(refined.size());
  // The float functions: the same basis without refinement, in f16 (its rounding is 2^-11).
  settings.components = 64 - m;
  settings.quantization = Quantization::F16;
  const Field f16 = bake(scene, settings, "builtin:sphere");
  const Field plain = withoutRefinement(u8, m);
  const auto plainValid = validateField(plain);
  ASSERT_TRUE(plainValid.ok()) << plainValid.error().message;
  std::vector<double> refinedErrors, plainErrors;
  Random rng{11};
  for (uint64_t texel : sampleTexels(u8, 7))
    for (int i = 0; i < 16; ++i) {
      const glm::dvec3 w = cosineDirection(rng, 0.05);
      const glm::dvec3 reference = decodedExit(f16, texel, w);
      refinedErrors.push_back(angleDegrees(decodedExit(u8, texel, w), reference));
      plainErrors.push_back(angleDegrees(decodedExit(plain, texel, w), reference));
    }
  std::printf("sphere pca 64 u8, %u refinement layers: mean angle to the float functions %.4f deg, "
              "without them %.4f deg (%zu)\n", m, mean(refinedErrors), mean(plainErrors), refinedErrors.size());
  EXPECT_LT(mean(refinedErrors), 0.5 * mean(plainErrors));
}


}  // namespace
}  // namespace shrefract::bake
