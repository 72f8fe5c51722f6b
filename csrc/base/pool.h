// A small thread pool (threads from platform.h): run fn(ctx, task, thread) for every task of a range on a fixed
// set of threads (the caller is thread 0), as many of them as the job's work fills and the machine has CPUs
// free for. Tasks are handed out dynamically, so results are deterministic only when a task's output does not
// depend on which thread ran it or how many ran: give each task its own output, and per-thread scratch by
// `thread` (always below od_Pool_Threads).
#pragma once

#include "opdeform/base.h"

typedef struct od_Pool od_Pool;
typedef void od_PoolFn(void* ctx, int task, int thread);

// The one thread limit of the core: every threaded object (a simulation's solver, a skin, an MPM world) takes
// 0..OD_POOL_MAX_THREADS threads, and per-thread arrays may be sized by it.
#define OD_POOL_MAX_THREADS 64

// OD_OK for 0 <= threads <= OD_POOL_MAX_THREADS, else OD_ERROR_ARGUMENT naming `threads`.
od_Status od_Pool_CheckThreads(int threads);
// What threads = 0 means: the CPUs this process may run on (its affinity mask), at most OMP_NUM_THREADS when
// that is set, clamped to [1, OD_POOL_MAX_THREADS].
int od_Pool_AvailableThreads(void);
// threads as od_Pool_CheckThreads accepts (0: od_Pool_AvailableThreads()). Creates threads - 1 workers.
// After a fork the child's copy runs every job on the calling thread (its workers are the parent's) and
// is destroyed without waiting for them.
od_Status od_Pool_Create(int threads, od_Pool** pool);
void od_Pool_Destroy(od_Pool* pool);
int od_Pool_Threads(const od_Pool* pool);
// The least work worth a thread of its own, in nanoseconds on one thread: waking a sleeping worker costs about
// 10 us (docs/speed.md, "Threads"), so a share is 5x that. The call sites' costs per item were measured on one
// thread (the 10,000-particle beam, 300,000 skinned vertices, the 97,336-particle snow block).
#define OD_POOL_MIN_WORK 50e3

// Runs tasks 0..count-1 and returns when all are done. `work`: the job's time on one thread in nanoseconds
// (its items times a cost per item measured on one thread); it runs on at most work / OD_POOL_MIN_WORK threads
// and at most on the CPUs free now (the machine's other runnable threads subtracted, Linux), the caller always
// one of them. Tasks a worker does not take in time the caller runs itself.
void od_Pool_Run(od_Pool* pool, int count, double work, od_PoolFn* fn, void* ctx);

// The items [*begin, *end) of `task` when `items` are cut into `tasks` nearly equal ranges.
static inline void od_TaskRange(int items, int tasks, int task, int* begin, int* end)
{
	*begin = (int)((long long)items * task / tasks);
	*end = (int)((long long)items * (task + 1) / tasks);
}
