// Every core of one machine (issue 22): the runs of a comparison or a sweep, each the run of one
// (definition, method or setting), are independent jobs, run over a pool of threads. A job owns
// its engine world or model and writes only its own result slot; the results are read in the
// jobs' order once all have ended, so a run with N threads gives what a serial run gives (the
// timings aside: CPU time is each run's own thread's, sim::thread_cpu_seconds). What the engines
// share between threads, and what is made safe or serialized, is listed in docs/engines.md
// ("Threads").
#pragma once

#include <cstddef>
#include <functional>

namespace crosslink::methods {

// The default number of threads: the machine's cores (std::thread::hardware_concurrency; 1 when
// it cannot tell).
int default_jobs();

// The most threads --jobs takes: a bound on input like every other.
constexpr int kMaxJobs = 1024;

// Runs job(i) for every i in [0, count) on at most `jobs` threads (the calling thread is one of
// them; jobs <= 1 runs them in turn on it). Jobs start in index order: `started(i)`, when given,
// is called just before job i starts, under the pool's lock, so progress reports come in the
// order a serial run gives. Once a job throws, no further job starts; when the running ones have
// ended, the exception of the lowest index is rethrown. Jobs start in order, so that is the one a
// serial run would have thrown.
void run_jobs(int jobs, size_t count, const std::function<void(size_t)>& job,
              const std::function<void(size_t)>& started = {});

}  // namespace crosslink::methods
