#include "tools/dfsm/batch_inputs.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>

#include "core/io/burst.h"

namespace dfsm::tools {
namespace {
namespace fs = std::filesystem;

class BatchInputsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dfsm_batch_inputs_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void Touch(const fs::path& file) {
    fs::create_directories(file.parent_path());
    std::ofstream(file) << "x";
  }
  std::string Burst(const std::string& relative) {
    Touch(dir_ / relative / "manifest.json");
    return (dir_ / relative).string();
  }

  fs::path dir_;
};

std::vector<std::string> NamesOf(const std::vector<BatchItem>& items) {
  std::vector<std::string> names;
  for (const BatchItem& item : items) names.push_back(item.name);
  return names;
}

// Burst directories, tars and dfsmd job directories one level down, named
// after their directory, tar or job, in name order.
TEST_F(BatchInputsTest, ADirectoryOfBurstsTarsAndJobs) {
  Burst("archive/b");
  Burst("archive/a");
  Touch(dir_ / "archive" / "c.tar");
  Touch(dir_ / "archive" / "job-7" / "burst.tar");
  Burst("archive/job-8/burst");           // a dfsmd job directory as it is on disk
  Burst("archive/calibration");           // the batch's own folder name: renamed
  Burst("archive/.hidden");               // hidden: ignored
  Touch(dir_ / "archive" / "notes.txt");  // not a burst: ignored
  const std::vector<BatchItem> items = ExpandBatchInputs({(dir_ / "archive").string()}, 0);
  EXPECT_EQ(NamesOf(items),
            (std::vector<std::string>{"a", "archive-calibration", "b", "c", "job-7", "job-8"}));
  EXPECT_FALSE(items[0].tar);
  EXPECT_TRUE(items[3].tar);
  EXPECT_TRUE(items[4].tar);
  EXPECT_EQ(fs::path(items[4].input).filename(), "burst.tar");
  EXPECT_EQ(fs::path(items[5].input).filename(), "burst");
}

// A name taken twice gets its parent's name; the same input given twice is
// one burst.
TEST_F(BatchInputsTest, NamesAreUniqueAndStable) {
  const std::string one = Burst("day1/scene");
  const std::string two = Burst("day2/scene");
  const std::vector<BatchItem> items = ExpandBatchInputs({two, one, one + "/", one + "/."}, 0);
  EXPECT_EQ(NamesOf(items), (std::vector<std::string>{"day1-scene", "day2-scene"}));
  EXPECT_EQ(NamesOf(ExpandBatchInputs({one, two}, 0)), NamesOf(items));
}

// The shards of a batch are disjoint, cover it, and differ by at most one
// burst in size.
TEST_F(BatchInputsTest, ShardsPartitionTheBatch) {
  std::vector<std::string> inputs;
  for (int k = 0; k < 11; ++k) inputs.push_back(Burst("many/b" + std::to_string(k)));
  const std::vector<BatchItem> items = ExpandBatchInputs({(dir_ / "many").string()}, 0);
  ASSERT_EQ(items.size(), 11u);
  std::multiset<std::string> seen;
  for (int index = 0; index < 3; ++index) {
    const std::vector<BatchItem> shard =
        ItemsOfShard(items, ParseShard(std::to_string(index) + "/3"));
    EXPECT_GE(shard.size(), 3u);
    EXPECT_LE(shard.size(), 4u);
    for (const BatchItem& item : shard) seen.insert(item.name);
  }
  EXPECT_EQ(seen.size(), 11u);
  EXPECT_EQ(std::set<std::string>(seen.begin(), seen.end()).size(), 11u);
  EXPECT_EQ(ParseShard("2/3").Suffix(), ".shard-2-of-3");
  EXPECT_EQ(ParseShard("0/1").Suffix(), "");
}

// A video in a directory of bursts that cannot be cut into windows (here:
// not a video at all) is one burst that fails with why; the others stand.
TEST_F(BatchInputsTest, ABrokenClipInADirectoryFailsAlone) {
  Burst("clips/a");
  Touch(dir_ / "clips" / "broken.mp4");
  const std::vector<BatchItem> items = ExpandBatchInputs({(dir_ / "clips").string()}, 5);
  ASSERT_EQ(NamesOf(items), (std::vector<std::string>{"a", "broken"}));
  EXPECT_TRUE(items[0].error.empty());
  EXPECT_NE(items[1].error.find("broken.mp4"), std::string::npos) << items[1].error;
}

TEST_F(BatchInputsTest, BadShardsAndInputsAreNamed) {
  for (const std::string bad : {"3/3", "-1/2", "1/0", "1", "a/b", "1/2x", "1/2/3"})
    EXPECT_THROW(ParseShard(bad), std::invalid_argument) << bad;
  EXPECT_THROW(ExpandBatchInputs({(dir_ / "absent").string()}, 0), BurstError);
  fs::create_directories(dir_ / "empty");
  try {
    ExpandBatchInputs({(dir_ / "empty").string()}, 0);
    FAIL() << "an empty directory was accepted";
  } catch (const BurstError& e) {
    EXPECT_NE(std::string(e.what()).find("holds no burst"), std::string::npos) << e.what();
  }
  Touch(dir_ / "notes.txt");
  EXPECT_THROW(ExpandBatchInputs({(dir_ / "notes.txt").string()}, 0), BurstError);
}

}  // namespace
}  // namespace dfsm::tools
