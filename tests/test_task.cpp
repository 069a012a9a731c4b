// A thread of the program (hal/os/task): named as asked (15 characters reach the
// kernel), its real-time settings taken before start() returns, a refusal said
// and the body run anyway, joined once.
#include <gtest/gtest.h>
#include <pthread.h>

#include <atomic>
#include <string>
#include <thread>

#include "hal/os/doorbell.hpp"
#include "hal/os/task.hpp"

namespace zonemap {
namespace {

std::string calling_thread_name() {
  char name[32] = {};
  pthread_getname_np(pthread_self(), name, sizeof name);
  return name;
}

TEST(Task, RunsItsBodyOnAThreadOfItsName) {
  std::string seen;
  std::thread::id body_thread;
  os::Task task;
  EXPECT_FALSE(task.started());
  task.start({"zonemap-test"}, [&] {
    seen = calling_thread_name();
    body_thread = std::this_thread::get_id();
  });
  EXPECT_TRUE(task.started());
  task.join();
  EXPECT_FALSE(task.started());
  EXPECT_EQ(seen, "zonemap-test");
  EXPECT_NE(body_thread, std::this_thread::get_id());
  EXPECT_TRUE(task.warning().empty()) << task.warning();
  task.join();  // a second join does nothing
}

TEST(Task, ALongNameIsCutToWhatTheKernelKeeps) {
  std::string seen;
  os::Task task;
  task.start({"zonemap-a-name-longer-than-fifteen"}, [&] { seen = calling_thread_name(); });
  task.join();
  EXPECT_EQ(seen, "zonemap-a-name-");
}

TEST(Task, ARefusedCpuIsSaidBeforeStartReturnsAndTheBodyStillRuns) {
  // The body cannot finish before the test has read the warning: start() must
  // have returned with the settings already taken (or refused).
  const int absent = static_cast<int>(std::thread::hardware_concurrency()) + 7;
  std::atomic<bool> may_finish{false}, finished{false};
  os::Doorbell bell;
  os::Task task;
  task.start({"zonemap-pinned", 0, absent}, [&] {
    for (;;) {
      const std::uint32_t ticket = bell.ticket();
      if (may_finish.load()) break;
      bell.wait(ticket);
    }
    finished.store(true);
  });
  const std::string warning = task.warning();
  EXPECT_FALSE(finished.load());
  may_finish.store(true);
  bell.ring();
  task.join();
  EXPECT_TRUE(finished.load());
  EXPECT_EQ(warning.rfind("zonemap-pinned: ", 0), 0u) << warning;
  EXPECT_NE(warning.find("CPU " + std::to_string(absent)), std::string::npos) << warning;
}

TEST(Task, TheDestructorJoins) {
  std::atomic<int> runs{0};
  {
    os::Task task;
    task.start({"zonemap-once"}, [&] { runs.fetch_add(1); });
  }
  EXPECT_EQ(runs.load(), 1);
}

}  // namespace
}  // namespace zonemap
