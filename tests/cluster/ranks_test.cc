// Issue #52: the hand-out of a batch's items in one process (the MPI path
// is cluster_cli_test's): every pending item runs once and its result is
// kept by item, on one thread or several; the kinds not yet measured go
// first, then the kind that has taken longest; an error stops the batch
// and is returned, as is the done callback's and an item outside the
// batch; items already done are not run again.
#include "cluster/ranks.h"

#include <chrono>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"

namespace kcrig {
namespace {

// Alone, a computation takes the default threads unless told; a
// --threads always wins.
TEST(RanksTest, ThreadsPerRankAloneAndAsRequested) {
  ASSERT_EQ(WorldRanks().size(), 1);
  EXPECT_EQ(ThreadsPerRank(WorldRanks()), kDefaultThreads);
  EXPECT_EQ(ThreadsPerRank(WorldRanks(), 3), 3);
  EXPECT_EQ(ThreadsPerRank(WorldRanks(), 1), 1);
}

TEST(RanksTest, EveryPendingItemRunsOnceAndIsKeptByItem) {
  for (int threads : {1, 3}) {
    std::vector<std::string> results(6, "kept");
    std::vector<int> calls(6, 0);
    std::mutex mutex;
    const Status status = WorldRanks().Distribute(
        {5, 1, 2, 4}, {}, threads,
        [&](int item, std::string* result) {
          std::lock_guard<std::mutex> lock(mutex);
          ++calls[item];
          *result = "item " + std::to_string(item);
          return Status::Ok();
        },
        nullptr, &results);
    ASSERT_TRUE(status.ok()) << status.message();
    EXPECT_EQ(results, (std::vector<std::string>{"kept", "item 1", "item 2",
                                                 "kept", "item 4", "item 5"}));
    EXPECT_EQ(calls, (std::vector<int>{0, 1, 1, 0, 1, 1}));
  }
}

TEST(RanksTest, UnmeasuredKindsFirstThenTheSlowestKind) {
  // Kind 1 takes 50 ms an item, kind 0 nothing, kind 2 nothing.
  const std::vector<int> kinds = {0, 1, 0, 1, 0, 1, 2};
  std::vector<std::string> results(kinds.size());
  std::vector<int> order;
  const Status status = WorldRanks().Distribute(
      {0, 1, 2, 3, 4, 5, 6}, kinds, 1,
      [&](int item, std::string*) {
        order.push_back(item);
        if (kinds[item] == 1) {
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
        return Status::Ok();
      },
      nullptr, &results);
  ASSERT_TRUE(status.ok()) << status.message();
  // 0 (kind 0, unmeasured), 1 (kind 1, unmeasured), 6 (kind 2,
  // unmeasured), then kind 1's items (slowest), then kind 0's.
  EXPECT_EQ(order, (std::vector<int>{0, 1, 6, 3, 5, 2, 4}));
}

TEST(RanksTest, AnErrorStopsTheBatchAndIsReturned) {
  std::vector<std::string> results(5);
  std::vector<int> ran;
  Status status = WorldRanks().Distribute(
      {0, 1, 2, 3, 4}, {}, 1,
      [&](int item, std::string*) {
        ran.push_back(item);
        return item == 1 ? Status::Error("case 1: bad") : Status::Ok();
      },
      nullptr, &results);
  EXPECT_EQ(status.message(), "case 1: bad");
  EXPECT_EQ(ran, (std::vector<int>{0, 1}));
  // The done callback's error (a checkpoint that cannot be written) too.
  ran.clear();
  status = WorldRanks().Distribute(
      {0, 1, 2}, {}, 1,
      [&](int item, std::string*) {
        ran.push_back(item);
        return Status::Ok();
      },
      [](int item, const std::string&, double seconds) {
        EXPECT_GE(seconds, 0.0);
        return item == 0 ? Status::Error("disk full") : Status::Ok();
      },
      &results);
  EXPECT_EQ(status.message(), "disk full");
  EXPECT_EQ(ran, (std::vector<int>{0}));
  // An item outside the batch fails it before anything runs.
  ran.clear();
  status = WorldRanks().Distribute(
      {0, 7}, {}, 1,
      [&](int item, std::string*) {
        ran.push_back(item);
        return Status::Ok();
      },
      nullptr, &results);
  EXPECT_EQ(status.message(), "item 7 is not in the batch");
  EXPECT_TRUE(ran.empty());
}

}  // namespace
}  // namespace kcrig
