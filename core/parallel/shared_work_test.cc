#include "core/parallel/shared_work.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

namespace dfsm {
namespace {

// Pieces that count how often each ran.
std::vector<std::function<void()>> CountingPieces(std::vector<std::atomic<int>>& runs) {
  std::vector<std::function<void()>> pieces;
  for (size_t i = 0; i < runs.size(); ++i) pieces.push_back([&runs, i] { ++runs[i]; });
  return pieces;
}

TEST(SharedWork, HelpersFromManyThreadsRunEveryPieceExactlyOnce) {
  std::vector<std::atomic<int>> runs(500);
  SharedWork work(CountingPieces(runs));
  std::vector<std::thread> helpers;
  for (int t = 0; t < 4; ++t) helpers.emplace_back([&work] { work.Help(); });
  for (std::thread& helper : helpers) helper.join();
  work.Finish();  // nothing left: returns at once
  EXPECT_EQ(work.taken(), 500);
  for (size_t i = 0; i < runs.size(); ++i) EXPECT_EQ(runs[i].load(), 1) << "piece " << i;
}

TEST(SharedWork, OneHelperRunsThePiecesInOrder) {
  // taken() counts the first pieces: a caller reads which ones ran where.
  std::vector<int> order;
  std::vector<std::function<void()>> pieces;
  for (int i = 0; i < 5; ++i) pieces.push_back([&order, i] { order.push_back(i); });
  SharedWork work(std::move(pieces));
  EXPECT_EQ(work.size(), 5);
  EXPECT_EQ(work.taken(), 0);
  work.Help();
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(work.taken(), 5);
}

TEST(SharedWork, FinishRunsEveryPieceLeftOnThePool) {
  std::vector<std::atomic<int>> runs(64);
  SharedWork work(CountingPieces(runs));
  work.Finish();
  EXPECT_EQ(work.taken(), 64);
  for (size_t i = 0; i < runs.size(); ++i) EXPECT_EQ(runs[i].load(), 1) << "piece " << i;
}

TEST(SharedWork, KeepsThePiecesErrorsAndGivesTheFirstInOrder) {
  std::vector<std::function<void()>> pieces = {[] {}, [] { throw std::runtime_error("second"); },
                                               [] { throw std::logic_error("third"); }};
  SharedWork work(std::move(pieces));
  EXPECT_NO_THROW(work.Help());
  EXPECT_EQ(work.taken(), 3);
  ASSERT_TRUE(work.FirstError());
  try {
    std::rethrow_exception(work.FirstError());
  } catch (const std::runtime_error& error) {
    EXPECT_STREQ(error.what(), "second");
  }
}

TEST(SharedWork, WithoutErrorsThereIsNone) {
  SharedWork work({[] {}, [] {}});
  work.Finish();
  EXPECT_FALSE(work.FirstError());
}

// A helper asked to go on only while something else runs stops between
// pieces; Finish runs what it left.
TEST(SharedWork, AHelperStopsBetweenPiecesWhenToldAndFinishRunsTheRest) {
  std::vector<std::atomic<int>> runs(8);
  SharedWork work(CountingPieces(runs));
  int asked = 0;
  work.Help([&asked] { return ++asked <= 3; });
  EXPECT_EQ(work.taken(), 3);
  EXPECT_EQ(runs[2].load(), 1);
  EXPECT_EQ(runs[3].load(), 0);
  work.Help([] { return false; });
  EXPECT_EQ(work.taken(), 3);
  work.Finish();
  EXPECT_EQ(work.taken(), 8);
  for (size_t i = 0; i < runs.size(); ++i) EXPECT_EQ(runs[i].load(), 1) << "piece " << i;
}

}  // namespace
}  // namespace dfsm
