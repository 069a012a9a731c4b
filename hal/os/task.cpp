#include "hal/os/task.hpp"

#include <pthread.h>

#include <future>

#include "hal/os/realtime.hpp"

namespace zonemap::os {
namespace {

// Linux keeps 15 characters of a thread's name.
void name_calling_thread(const char* name) {
  char truncated[16] = {};
  for (int i = 0; i < 15 && name[i] != '\0'; ++i) truncated[i] = name[i];
  pthread_setname_np(pthread_self(), truncated);
}

}  // namespace

void Task::start(const TaskSettings& settings, std::function<void()> body) {
  join();
  warning_.clear();
  // The shared state outlives whichever side lets go of it last.
  std::promise<void> set_up;
  std::future<void> taken = set_up.get_future();
  thread_ =
      std::thread([this, settings, done = std::move(set_up), run = std::move(body)]() mutable {
        name_calling_thread(settings.name);
        std::string refused;
        if ((settings.priority > 0 || settings.cpu >= 0) &&
            !set_thread_realtime(settings.priority, settings.cpu, &refused)) {
          warning_ = std::string(settings.name) + ": " + refused;
        }
        done.set_value();
        run();
      });
  taken.wait();
}

void Task::join() {
  if (thread_.joinable()) thread_.join();
}

}  // namespace zonemap::os
