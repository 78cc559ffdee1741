// The bake's settings: what a field records of how it was baked (field.h BakeRecord) and the
// switches of the bake driver that leave nothing in a field (each says what it chooses).
#pragma once

#include <shrefract/field.h>

namespace shrefract {

struct BakeSettings : BakeRecord {
  // With tryVolume (the tool's default): the image contest instead of the scene's decision, far
  // slower and larger (docs/encodings.md, "The default encoding").
  bool chooseByImages = false;
  // A Volume field (asked for, or kept by tryVolume) whose texels predict the paths between them
  // poorly is laid out again at more samples (bake.h kVolumeDensifyBelowDb): the tool's default
  // when no --samples or --density is given. Not stored in a field (its sampleBudget is the budget it was laid out at);
  // a part file carries it, so that a merge does what the bake would.
  bool volumeDensify = false;
  // Pca without `clusters`: also tries 3 times as many clusters as components (bake/src/driver/basis.cpp
  // kDefaultClustersPerComponent; where the samples hold 8 a cluster and the tables fit 64 MiB) and
  // keeps the closest on the traced views. With --choose-by-images and no --components or
  // --clusters: a cluster's table is stored once per field, so more of them cost memory, not bytes per
  // sample. Not stored in a field (its `components` says how many it kept); a part file carries it.
  bool moreClusters = false;
  // The path rule chosen by measurement: the bake renders both rules' exact paths and the full
  // Fresnel tree at the image choice's views and keeps highest-energy where its exact renders come
  // at least kHighestEnergyGainDb closer to the tree (bake.h), first-refraction otherwise. With
  // --choose-by-images where no --path-rule is given. Not stored in a field (its pathRule is the rule chosen).
  bool choosePathRule = false;
};

// A field's record as settings to bake with again (the driver's switches off).
inline BakeSettings bakeSettingsOf(const BakeRecord& record) {
  BakeSettings s;
  static_cast<BakeRecord&>(s) = record;
  return s;
}

}  // namespace shrefract
