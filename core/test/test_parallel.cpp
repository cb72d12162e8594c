#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <thread>

#include "pplvo/core/parallel.h"

namespace {

int niceOfThisThread() {
  errno = 0;
  return getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
}

TEST(ThreadPriority, LowersOnlyTheCallingThreadAndWhatItStarts) {
  const int main_before = niceOfThisThread();
  if (main_before + 3 > 19) GTEST_SKIP() << "already at nice " << main_before;
  int worker = -100, child = -100;
  bool lowered = false;
  std::thread t([&] {
    lowered = pplvo::lowerThisThreadsPriority(3);
    worker = niceOfThisThread();
    std::thread c([&] { child = niceOfThisThread(); });  // inherits its creator's value
    c.join();
  });
  t.join();
  ASSERT_TRUE(lowered);
  EXPECT_EQ(worker, main_before + 3);
  EXPECT_EQ(child, main_before + 3);
  EXPECT_EQ(niceOfThisThread(), main_before);  // the rest of the process is untouched
}

TEST(ForEachTask, RunsEveryTaskOnceWithAndWithoutThreads) {
  for (const int threads : {1, 2, 4}) {
    std::atomic<int> hits[7] = {};
    pplvo::forEachTask(7, threads, [&](int i) { ++hits[i]; });
    for (const auto& h : hits) EXPECT_EQ(h.load(), 1) << threads;
  }
}

}  // namespace
