#include "core/sparse/sparse_layers.h"

#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <string>

namespace dfsm {
namespace {

// The defaults run every layer, and each name switches its own layer off and
// no other: a bench's `--without X` measures X alone.
TEST(SparseLayers, EachNameSwitchesItsOwnLayerOff) {
  const SparseOptions defaults;
  std::set<std::string> names;
  for (const SparseLayerInfo& info : SparseLayers()) {
    EXPECT_TRUE(names.insert(info.name).second) << info.name;
    EXPECT_EQ(ParseSparseLayer(info.name), info.layer);
    EXPECT_STREQ(SparseLayerName(info.layer), info.name);
    ASSERT_TRUE(UsesLayer(defaults, info.layer)) << info.name;
    const SparseOptions without = WithoutLayers(defaults, info.name);
    for (const SparseLayerInfo& other : SparseLayers())
      EXPECT_EQ(UsesLayer(without, other.layer), other.layer != info.layer)
          << "without " << info.name << ", " << other.name;
    EXPECT_NO_THROW(without.Check()) << info.name;
  }
}

TEST(SparseLayers, AListSwitchesSeveralAndAnUnknownNameIsNamed) {
  const SparseOptions without = WithoutLayers(SparseOptions(), "naive-probe,bias");
  EXPECT_FALSE(UsesLayer(without, SparseLayer::kNaiveProbe));
  EXPECT_FALSE(UsesLayer(without, SparseLayer::kBootstrapBias));
  EXPECT_TRUE(UsesLayer(without, SparseLayer::kFocalStarts));
  try {
    WithoutLayers(SparseOptions(), "naive-probe,bais");
    FAIL() << "a misspelt layer was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("\"bais\""), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("naive-probe"), std::string::npos) << e.what();
  }
  EXPECT_THROW(WithoutLayers(SparseOptions(), ""), std::invalid_argument);
}

}  // namespace
}  // namespace dfsm
