// Thread pool. Design: workers wait for a job's generation number to change, then take task indices from an
// atomic counter; the caller works too and waits until every task is finished. Waiting spins for a short
// while (OD_POOL_SPIN pauses, some tens of microseconds) before sleeping on a condition variable: each
// iteration of a step runs four short jobs (a local sweep, a right side, two substitution passes), and a
// sleep-and-wake costs about as much as one. One job at a time; no allocation after creation.
//
// Fork: a child has only the thread that forked, so it must never wait on a worker. An atfork handler
// counts forks; a pool made before the last fork runs its jobs on the calling thread (same tasks, same
// results: tasks never depend on the thread that runs them) and its destruction joins nothing. Re-creating
// workers in the child was not chosen: a forked child is usually one of several (multiprocessing.Pool),
// where one thread each already fills the cores. The prepare handler also shuts down the OpenMP thread team
// of the forking thread (omp_pause_resource_all, OpenMP 5.0), which CHOLMOD's supernodal factorization
// starts: libgomp's team does not survive fork either (measured: a child refactoring hung forever). Threads,
// locks, the CPU count and the fork hooks come from platform.h (Windows has no fork: the count stays 0).
#include "pool.h"

#include "core.h"
#include "platform.h"

#include <stdbool.h>
#include <stdatomic.h>
#include <stdlib.h>

typedef struct od_PoolWorker
{
	struct od_Pool* pool;
	int thread;
} od_PoolWorker;

struct od_Pool
{
	int threads;
	int spin;  // pauses before sleeping: OD_POOL_SPIN, or 0 with more threads than CPUs
	int forks; // od_forks when created
	od_Thread* workers;
	od_PoolWorker* args;
	od_Mutex lock;
	od_Cond wake, done;
	atomic_llong generation;
	atomic_int quit;
	// the current job
	od_PoolFn* fn;
	void* ctx;
	int count;
	atomic_int next;
	atomic_int running; // workers still inside the current job
};

#define OD_POOL_SPIN 20000

// ---------------------------------------------------------------------------------------------------------
// Fork

static atomic_int od_forks;
static od_Once od_atforkOnce = OD_ONCE_INIT;

static void od_Pool_BeforeFork(void)
{
	od_Platform_PauseOpenMP();
}

static void od_Pool_InChild(void)
{
	atomic_fetch_add(&od_forks, 1);
}

static void od_Pool_RegisterAtFork(void)
{
	od_Platform_AtFork(od_Pool_BeforeFork, od_Pool_InChild);
}

static bool od_Pool_Forked(const od_Pool* pool)
{
	return pool->forks != atomic_load(&od_forks);
}

// ---------------------------------------------------------------------------------------------------------
// Thread counts

od_Status od_Pool_CheckThreads(int threads)
{
	if (threads < 0 || threads > OD_POOL_MAX_THREADS)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "threads = %d must be in [0, %d] (0: the CPUs this process may use)",
					   threads, OD_POOL_MAX_THREADS);
	}
	return OD_OK;
}

// OMP_NUM_THREADS as a count (its first entry), or 0 when unset or not a positive number.
static int od_OmpThreads(void)
{
	const char* text = getenv("OMP_NUM_THREADS");
	char* end;
	long count = text ? strtol(text, &end, 10) : 0;
	return text && end != text && count > 0 ? (int)(count < OD_POOL_MAX_THREADS ? count : OD_POOL_MAX_THREADS) : 0;
}

int od_Pool_AvailableThreads(void)
{
	int cpus = od_Platform_Cpus();
	int omp = od_OmpThreads();
	cpus = omp > 0 && omp < cpus ? omp : cpus;
	return cpus < 1 ? 1 : cpus > OD_POOL_MAX_THREADS ? OD_POOL_MAX_THREADS : cpus;
}

// ---------------------------------------------------------------------------------------------------------
// Workers

static bool od_NewJob(od_Pool* pool, long long seen)
{
	return atomic_load(&pool->generation) != seen || atomic_load(&pool->quit);
}

static bool od_JobDone(od_Pool* pool, long long seen)
{
	(void)seen;
	return atomic_load(&pool->running) == 0;
}

// Spins until done(pool, seen) or the spin budget is spent; true when it came true.
static bool od_SpinUntil(bool (*done)(od_Pool*, long long), od_Pool* pool, long long seen)
{
	for (int k = 0; k < pool->spin; ++k)
	{
		if (done(pool, seen))
		{
			return true;
		}
		od_Platform_Pause();
	}
	return false;
}

static void od_Pool_Work(od_Pool* pool, int thread)
{
	for (int task; (task = atomic_fetch_add(&pool->next, 1)) < pool->count;)
	{
		pool->fn(pool->ctx, task, thread);
	}
}

static void* od_Pool_Main(void* arg)
{
	od_PoolWorker* w = arg;
	od_Pool* pool = w->pool;
	int thread = w->thread;
	long long seen = 0;
	for (;;)
	{
		if (!od_SpinUntil(od_NewJob, pool, seen))
		{
			od_Mutex_Lock(&pool->lock);
			while (!atomic_load(&pool->quit) && atomic_load(&pool->generation) == seen)
			{
				od_Cond_Wait(&pool->wake, &pool->lock);
			}
			od_Mutex_Unlock(&pool->lock);
		}
		if (atomic_load(&pool->quit))
		{
			break;
		}
		seen = atomic_load(&pool->generation);
		od_Pool_Work(pool, thread);
		if (atomic_fetch_sub(&pool->running, 1) == 1)
		{
			od_Mutex_Lock(&pool->lock); // the caller may be about to sleep on `done`
			od_Cond_Signal(&pool->done);
			od_Mutex_Unlock(&pool->lock);
		}
	}
	return NULL;
}

od_Status od_Pool_Create(int threads, od_Pool** out)
{
	*out = NULL;
	od_Status status = od_Pool_CheckThreads(threads);
	if (status != OD_OK)
	{
		return status;
	}
	od_RunOnce(&od_atforkOnce, od_Pool_RegisterAtFork);
	int available = od_Pool_AvailableThreads();
	threads = threads == 0 ? available : threads;
	od_Pool* pool = od_AllocZero(1, sizeof *pool);
	if (pool)
	{
		pool->args = od_AllocZero((size_t)threads, sizeof *pool->args);
		pool->workers = od_AllocZero((size_t)threads, sizeof *pool->workers);
	}
	if (!pool || !pool->args || !pool->workers)
	{
		od_Pool_Destroy(pool);
		return od_Fail(OD_ERROR_MEMORY, "thread pool: out of memory");
	}
	pool->threads = 1;
	pool->forks = atomic_load(&od_forks);
	// More threads than CPUs: a spinning waiter holds the CPU that the thread it waits for needs (measured,
	// see docs/hardening.md), so waiters sleep at once.
	pool->spin = threads <= available ? OD_POOL_SPIN : 0;
	od_Mutex_Init(&pool->lock);
	od_Cond_Init(&pool->wake);
	od_Cond_Init(&pool->done);
	for (int t = 1; t < threads; ++t)
	{
		pool->args[t] = (od_PoolWorker){ pool, t };
		if (!od_Thread_Start(&pool->workers[t], od_Pool_Main, &pool->args[t]))
		{
			break; // fewer threads than asked: still correct
		}
		pool->threads = t + 1;
	}
	*out = pool;
	return OD_OK;
}

void od_Pool_Destroy(od_Pool* pool)
{
	if (!pool)
	{
		return;
	}
	if (pool->workers && pool->args && !od_Pool_Forked(pool))
	{
		od_Mutex_Lock(&pool->lock);
		atomic_store(&pool->quit, 1);
		od_Cond_Broadcast(&pool->wake);
		od_Mutex_Unlock(&pool->lock);
		for (int t = 1; t < pool->threads; ++t)
		{
			od_Thread_Join(&pool->workers[t]);
		}
		od_Mutex_Destroy(&pool->lock);
		od_Cond_Destroy(&pool->wake);
		od_Cond_Destroy(&pool->done);
	}
	od_Free(pool->workers);
	od_Free(pool->args);
	od_Free(pool);
}

int od_Pool_Threads(const od_Pool* pool)
{
	return pool->threads;
}

void od_Pool_Run(od_Pool* pool, int count, od_PoolFn* fn, void* ctx)
{
	if (count <= 0)
	{
		return;
	}
	if (pool->threads == 1 || count == 1 || od_Pool_Forked(pool))
	{
		for (int task = 0; task < count; ++task)
		{
			fn(ctx, task, 0);
		}
		return;
	}
	od_Mutex_Lock(&pool->lock);
	pool->fn = fn;
	pool->ctx = ctx;
	pool->count = count;
	atomic_store(&pool->next, 0);
	atomic_store(&pool->running, pool->threads - 1);
	atomic_fetch_add(&pool->generation, 1);
	od_Cond_Broadcast(&pool->wake);
	od_Mutex_Unlock(&pool->lock);
	od_Pool_Work(pool, 0);
	if (!od_SpinUntil(od_JobDone, pool, 0))
	{
		od_Mutex_Lock(&pool->lock);
		while (atomic_load(&pool->running) > 0)
		{
			od_Cond_Wait(&pool->done, &pool->lock);
		}
		od_Mutex_Unlock(&pool->lock);
	}
}
