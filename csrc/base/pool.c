// Thread pool. Design: a job is published with a member word (open flag, the workers it wants, the workers
// inside); a worker that sees a new job joins it by a compare-and-swap while it is open and not full, then takes
// task indices from an atomic counter; the caller works too, closes the job when no task is left to take, and
// waits only for the workers that joined. A worker that wakes late (its CPU held by other work) finds the job
// closed and costs the caller nothing: the caller ran its tasks. Results never depend on who joined: the tasks
// are the same, only the threads that run them differ.
//
// Threads per job: at most the job's work (nanoseconds on one thread, the caller's estimate) over
// OD_POOL_MIN_WORK, and at most the CPUs free now: the process's CPUs less the runnable threads that are not
// ours (platform.h's od_Platform_RunningThreads, re-read at most every OD_POOL_LOAD_SECONDS; the caller and
// this pool's spinning workers are ours). Waiting spins for OD_POOL_SPIN_SECONDS before sleeping on a condition
// variable, and only while the last job found every thread's CPU free: each iteration of a step runs four short
// jobs back to back (a local sweep, a right side, two substitution passes), where a sleep-and-wake costs about
// as much as one; on a loaded machine a spinning worker would take the CPU the caller needs. One job at a time;
// no allocation after creation.
//
// Fork: a child has only the thread that forked, so it must never wait on a worker. An atfork handler
// counts forks; a pool made before the last fork runs its jobs on the calling thread (same tasks, same
// results: tasks never depend on the thread that runs them) and its destruction joins nothing. Re-creating
// workers in the child was not chosen: a forked child is usually one of several (multiprocessing.Pool),
// where one thread each already fills the cores. The prepare handler also shuts down the OpenMP thread team
// of the forking thread (omp_pause_resource_all, OpenMP 5.0), which CHOLMOD's supernodal factorization
// starts: libgomp's team does not survive fork either (measured: a child refactoring hung forever). Threads,
// locks, the CPU count, the machine's load and the fork hooks come from platform.h (Windows has no fork: the
// count stays 0).
#include "pool.h"

#include "clock.h"
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

// A job's member word: open while the caller may still be taking tasks, the workers it wants, the workers inside.
#define OD_JOB_OPEN (1 << 30)
#define OD_JOB_WANT_SHIFT 8
#define OD_JOB_INSIDE 0xff

struct od_Pool
{
	int threads;
	int cpus;          // od_Pool_AvailableThreads() when created
	int forks;         // od_forks when created
	double loadReadAt; // when `others` was read (od_Clock), by the caller
	int others;        // runnable threads not ours then, or -1 where unknown
	od_Thread* workers;
	od_PoolWorker* args;
	od_Mutex lock;
	od_Cond wake, done;
	atomic_llong generation;
	atomic_int quit;
	atomic_int spin;          // whether waiters spin before sleeping: the last job found every thread a free CPU
	atomic_int spinning;      // workers spinning now
	atomic_int sleeping;      // workers asleep on `wake`
	atomic_int callerWaiting; // the caller asleep on `done`
	// the current job
	od_PoolFn* fn;
	void* ctx;
	int count;
	atomic_int next;
	atomic_int members;
};

// Waiting spins this long before sleeping (some tens of microseconds: the gap between a step's jobs).
#define OD_POOL_SPIN_SECONDS 100e-6
// The machine's runnable threads are re-read at most this often (reading costs about a microsecond on Linux).
#define OD_POOL_LOAD_SECONDS 1e-3

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

// The CPUs free for a job now: the process's CPUs less the runnable threads that are not ours (the caller and
// this pool's spinning workers are), at least 1; all of them where the machine's load is unknown.
static int od_Pool_FreeCpus(od_Pool* pool)
{
	double now = od_Clock();
	if (now - pool->loadReadAt >= OD_POOL_LOAD_SECONDS)
	{
		int running = od_Platform_RunningThreads();
		pool->others = running < 0 ? -1 : running - 1 - atomic_load(&pool->spinning);
		pool->loadReadAt = now;
	}
	int free = pool->others < 0 ? pool->cpus : pool->cpus - pool->others;
	return free < 1 ? 1 : free;
}

// The threads of a job: what its work fills (OD_POOL_MIN_WORK nanoseconds each), its tasks, the pool's and the
// free CPUs allow, at least 1 (the caller).
static int od_Pool_Want(od_Pool* pool, int count, double work)
{
	double filled = work / OD_POOL_MIN_WORK;
	int want = filled < pool->threads ? (int)filled : pool->threads;
	want = want < count ? want : count;
	if (want < 2)
	{
		return 1;
	}
	int free = od_Pool_FreeCpus(pool);
	atomic_store(&pool->spin, free >= pool->threads);
	return want < free ? want : free;
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
	return (atomic_load(&pool->members) & OD_JOB_INSIDE) == 0;
}

// Spins until done(pool, seen) or OD_POOL_SPIN_SECONDS have passed; true when it came true.
static bool od_SpinUntil(bool (*done)(od_Pool*, long long), od_Pool* pool, long long seen)
{
	double until = od_Clock() + OD_POOL_SPIN_SECONDS;
	do
	{
		for (int k = 0; k < 64; ++k)
		{
			if (done(pool, seen))
			{
				return true;
			}
			od_Platform_Pause();
		}
	} while (od_Clock() < until);
	return false;
}

static void od_Pool_WaitForJob(od_Pool* pool, long long seen)
{
	if (atomic_load(&pool->spin))
	{
		atomic_fetch_add(&pool->spinning, 1);
		bool found = od_SpinUntil(od_NewJob, pool, seen);
		atomic_fetch_sub(&pool->spinning, 1);
		if (found)
		{
			return;
		}
	}
	od_Mutex_Lock(&pool->lock);
	atomic_fetch_add(&pool->sleeping, 1); // before the check below: od_Pool_Publish reads it after its change
	while (!od_NewJob(pool, seen))
	{
		od_Cond_Wait(&pool->wake, &pool->lock);
	}
	atomic_fetch_sub(&pool->sleeping, 1);
	od_Mutex_Unlock(&pool->lock);
}

// Enters the open job when it wants another worker; false when it is closed or full.
static bool od_Pool_Join(od_Pool* pool)
{
	int m = atomic_load(&pool->members);
	while ((m & OD_JOB_OPEN) && (m & OD_JOB_INSIDE) < ((m >> OD_JOB_WANT_SHIFT) & OD_JOB_INSIDE))
	{
		if (atomic_compare_exchange_weak(&pool->members, &m, m + 1))
		{
			return true;
		}
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

static void od_Pool_Leave(od_Pool* pool)
{
	int m = atomic_fetch_sub(&pool->members, 1) - 1;
	if ((m & (OD_JOB_OPEN | OD_JOB_INSIDE)) == 0 && atomic_load(&pool->callerWaiting))
	{
		od_Mutex_Lock(&pool->lock);
		od_Cond_Signal(&pool->done);
		od_Mutex_Unlock(&pool->lock);
	}
}

static void* od_Pool_Main(void* arg)
{
	od_PoolWorker* w = arg;
	od_Pool* pool = w->pool;
	long long seen = 0;
	for (;;)
	{
		od_Pool_WaitForJob(pool, seen);
		if (atomic_load(&pool->quit))
		{
			break;
		}
		seen = atomic_load(&pool->generation);
		if (od_Pool_Join(pool))
		{
			od_Pool_Work(pool, w->thread);
			od_Pool_Leave(pool);
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
	pool->cpus = available;
	pool->forks = atomic_load(&od_forks);
	pool->loadReadAt = -1.0; // read on the first job
	// More threads than CPUs: a spinning waiter holds the CPU that the thread it waits for needs (measured,
	// see docs/hardening.md), so waiters sleep at once.
	atomic_store(&pool->spin, threads <= available);
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

// Opens a job for `workers` workers and wakes as many sleeping ones.
static void od_Pool_Publish(od_Pool* pool, int count, int workers, od_PoolFn* fn, void* ctx)
{
	pool->fn = fn;
	pool->ctx = ctx;
	pool->count = count;
	atomic_store(&pool->next, 0);
	atomic_store(&pool->members, OD_JOB_OPEN | workers << OD_JOB_WANT_SHIFT);
	atomic_fetch_add(&pool->generation, 1);
	int sleeping = atomic_load(&pool->sleeping);
	if (sleeping > 0)
	{
		od_Mutex_Lock(&pool->lock);
		for (int k = 0; k < workers && k < sleeping; ++k)
		{
			od_Cond_Signal(&pool->wake);
		}
		od_Mutex_Unlock(&pool->lock);
	}
}

// Closes the job to latecomers and waits for the workers inside.
static void od_Pool_Close(od_Pool* pool)
{
	atomic_fetch_and(&pool->members, ~OD_JOB_OPEN);
	if (od_SpinUntil(od_JobDone, pool, 0))
	{
		return;
	}
	od_Mutex_Lock(&pool->lock);
	atomic_store(&pool->callerWaiting, 1); // before the check below: od_Pool_Leave reads it after its change
	while (!od_JobDone(pool, 0))
	{
		od_Cond_Wait(&pool->done, &pool->lock);
	}
	atomic_store(&pool->callerWaiting, 0);
	od_Mutex_Unlock(&pool->lock);
}

void od_Pool_Run(od_Pool* pool, int count, double work, od_PoolFn* fn, void* ctx)
{
	if (count <= 0)
	{
		return;
	}
	int want = pool->threads == 1 || count == 1 || od_Pool_Forked(pool) ? 1 : od_Pool_Want(pool, count, work);
	if (want == 1)
	{
		for (int task = 0; task < count; ++task)
		{
			fn(ctx, task, 0);
		}
		return;
	}
	od_Pool_Publish(pool, count, want - 1, fn, ctx);
	od_Pool_Work(pool, 0);
	od_Pool_Close(pool);
}
