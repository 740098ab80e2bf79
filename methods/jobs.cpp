// The pool of threads of a comparison or a sweep (jobs.h).
#include "methods/jobs.h"

#include <algorithm>
#include <exception>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace crosslink::methods {

int default_jobs() {
  const unsigned cores = std::thread::hardware_concurrency();
  return cores == 0 ? 1 : static_cast<int>(std::min<unsigned>(cores, kMaxJobs));
}

void run_jobs(int jobs, size_t count, const std::function<void(size_t)>& job,
              const std::function<void(size_t)>& started) {
  if (jobs <= 1 || count <= 1) {
    for (size_t i = 0; i < count; ++i) {
      if (started) started(i);
      job(i);
    }
    return;
  }
  std::mutex lock;
  size_t next = 0;
  bool stop = false;
  std::map<size_t, std::exception_ptr> failed;  // by job index
  const auto work = [&] {
    for (;;) {
      size_t i = 0;
      {
        const std::lock_guard<std::mutex> hold(lock);
        if (stop || next == count) return;
        i = next++;
        if (started) {
          try {
            started(i);
          } catch (...) {
            failed.emplace(i, std::current_exception());
            stop = true;
            return;
          }
        }
      }
      try {
        job(i);
      } catch (...) {
        const std::lock_guard<std::mutex> hold(lock);
        failed.emplace(i, std::current_exception());
        stop = true;
      }
    }
  };
  const size_t threads = std::min(static_cast<size_t>(jobs), count);
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (!failed.empty()) std::rethrow_exception(failed.begin()->second);
}

}  // namespace crosslink::methods
