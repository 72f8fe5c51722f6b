// A small pthread pool: run fn(ctx, task, thread) for every task of a range on a fixed set of threads
// (the caller is thread 0). Tasks are handed out dynamically, so results are deterministic only when a
// task's output does not depend on which thread ran it: give each task its own output, and per-thread
// scratch by `thread`.
#pragma once

#include "opdeform/base.h"

typedef struct od_Pool od_Pool;
typedef void od_PoolFn(void* ctx, int task, int thread);

// threads <= 0: one per online core. Creates threads - 1 workers.
od_Status od_Pool_Create(int threads, od_Pool** pool);
void od_Pool_Destroy(od_Pool* pool);
int od_Pool_Threads(const od_Pool* pool);
// Runs tasks 0..count-1 and returns when all are done.
void od_Pool_Run(od_Pool* pool, int count, od_PoolFn* fn, void* ctx);

// The items [*begin, *end) of `task` when `items` are cut into `tasks` nearly equal ranges.
static inline void od_TaskRange(int items, int tasks, int task, int* begin, int* end)
{
	*begin = (int)((long long)items * task / tasks);
	*end = (int)((long long)items * (task + 1) / tasks);
}
