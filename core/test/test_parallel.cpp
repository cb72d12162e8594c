#include <gtest/gtest.h>

#include <atomic>

#include "pplvo/core/parallel.h"

namespace {

TEST(ForEachTask, RunsEveryTaskOnceWithAndWithoutThreads) {
  for (const int threads : {1, 2, 4}) {
    std::atomic<int> hits[7] = {};
    pplvo::forEachTask(7, threads, [&](int i) { ++hits[i]; });
    for (const auto& h : hits) EXPECT_EQ(h.load(), 1) << threads;
  }
}

}  // namespace
