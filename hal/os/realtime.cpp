#include "hal/os/realtime.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace zonemap::os {

bool cpu_runs_this_build(std::string* missing) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  std::string absent;
#if defined(__SSSE3__)
  if (!__builtin_cpu_supports("ssse3")) absent += " ssse3";
#endif
#if defined(__SSE4_1__)
  if (!__builtin_cpu_supports("sse4.1")) absent += " sse4.1";
#endif
#if defined(__SSE4_2__)
  if (!__builtin_cpu_supports("sse4.2")) absent += " sse4.2";
#endif
#if defined(__POPCNT__)
  if (!__builtin_cpu_supports("popcnt")) absent += " popcnt";
#endif
#if defined(__AVX2__)
  if (!__builtin_cpu_supports("avx2")) absent += " avx2";
#endif
  if (!absent.empty()) {
    *missing = "this CPU lacks" + absent +
               ", which the build was compiled for: rebuild with -DZONEMAP_X86_LEVEL=x86-64";
    return false;
  }
#endif
  (void)missing;
  return true;
}

bool lock_memory(std::string* warning) {
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) return true;
  *warning = std::string("mlockall failed (") + std::strerror(errno) +
             "): memory may be paged out; run with CAP_IPC_LOCK or a higher RLIMIT_MEMLOCK";
  return false;
}

bool set_thread_realtime(int priority, int cpu, std::string* warning) {
  bool ok = true;
  if (priority > 0) {
    sched_param param{};
    param.sched_priority = priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
    if (rc != 0) {
      *warning = std::string("SCHED_FIFO ") + std::to_string(priority) + " refused (" +
                 std::strerror(rc) + "): running with normal scheduling";
      ok = false;
    }
  }
  if (cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<unsigned>(cpu), &set);
    const int rc = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
    if (rc != 0) {
      *warning += std::string(ok ? "" : "; ") + "CPU " + std::to_string(cpu) +
                  " affinity refused (" + std::strerror(rc) + ")";
      ok = false;
    }
  }
  return ok;
}

long resident_bytes() {
  // open/read, not fopen: no allocation, so the output thread may ask (health).
  const int fd = ::open("/proc/self/statm", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0;
  char text[128];
  const ssize_t n = ::read(fd, text, sizeof text - 1);
  ::close(fd);
  if (n <= 0) return 0;
  text[n] = '\0';
  long pages_total = 0, pages_resident = 0;
  if (std::sscanf(text, "%ld %ld", &pages_total, &pages_resident) != 2) return 0;
  return pages_resident * sysconf(_SC_PAGESIZE);
}

}  // namespace zonemap::os
