#include "pplvo/core/parallel.h"

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#endif

namespace pplvo {

bool lowerThisThreadsPriority(int nice) {
#if defined(__linux__)
  // On Linux a nice value belongs to a thread (its tid), unlike POSIX's per-process one.
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (errno != 0) return false;
  return setpriority(PRIO_PROCESS, tid, now + nice) == 0;
#else
  (void)nice;
  return false;
#endif
}

}  // namespace pplvo
