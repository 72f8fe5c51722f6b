// What differs between Linux, macOS and Windows, behind one interface (platform.c): the CPUs this process may
// use, whether they run AVX2 + FMA, and how many threads run on them now, threads, a mutex and a condition variable, run-once, fork hooks, the monotonic clock (clock.h) and the
// spin-wait hint. No other file of the core calls an operating system's API.
#pragma once

#include <stdbool.h>

// Where the AVX2 kernels are compiled (target attributes, <immintrin.h>, cpuid): GCC or Clang on x86-64, unless
// built with -DOD_NO_VECTOR_EXTENSIONS. The build targets the baseline; od_Platform_HasAvx2Fma picks at run time.
#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) && !defined(OD_NO_VECTOR_EXTENSIONS)
#define OD_X86_AVX2 1
#endif

#ifdef _WIN32
// The Win32 objects, each one pointer wide (HANDLE, SRWLOCK, CONDITION_VARIABLE, INIT_ONCE): <windows.h> stays
// inside platform.c.
typedef struct od_Thread
{
	void* handle;
	void* (*fn)(void*);
	void* arg;
} od_Thread;
typedef struct od_Mutex
{
	void* lock;
} od_Mutex;
typedef struct od_Cond
{
	void* cond;
} od_Cond;
typedef struct od_Once
{
	void* once;
} od_Once;
#define OD_ONCE_INIT { 0 }
#else
#include <pthread.h>
typedef pthread_t od_Thread;
typedef pthread_mutex_t od_Mutex;
typedef pthread_cond_t od_Cond;
typedef pthread_once_t od_Once;
#define OD_ONCE_INIT PTHREAD_ONCE_INIT
#endif

// The CPUs this process may run on: its affinity mask (Linux: sched_getaffinity; Windows: the process affinity
// mask, else GetActiveProcessorCount), the active CPUs on macOS (sysctl hw.activecpu: no affinity there); 0
// when unknown.
int od_Platform_Cpus(void);

// The threads runnable right now on the CPUs this process may use, the caller included (Linux: /proc/loadavg's
// count of runnable threads, times Cpus() over the machine's online CPUs where the process may use fewer);
// -1 where unknown (macOS, Windows: there every CPU of the affinity mask counts as free).
int od_Platform_RunningThreads(void);

// Whether the AVX2 + FMA kernels run: an x86-64 processor with both whose operating system saves the ymm registers
// (cpuid and xgetbv, no runtime library), in a GCC or Clang build; false elsewhere, and when the environment sets
// OPDEFORM_NO_AVX2 to anything but "" or "0" (the baseline kernels on any processor: tests, comparisons). Read once.
bool od_Platform_HasAvx2Fma(void);

// Starts fn(arg) on a new thread; false when it could not. *thread stays where it is until joined.
bool od_Thread_Start(od_Thread* thread, void* (*fn)(void*), void* arg);
void od_Thread_Join(od_Thread* thread);

void od_Mutex_Init(od_Mutex* mutex);
void od_Mutex_Destroy(od_Mutex* mutex);
void od_Mutex_Lock(od_Mutex* mutex);
void od_Mutex_Unlock(od_Mutex* mutex);

void od_Cond_Init(od_Cond* cond);
void od_Cond_Destroy(od_Cond* cond);
// Releases mutex (held), sleeps until signalled (or spuriously), takes mutex again.
void od_Cond_Wait(od_Cond* cond, od_Mutex* mutex);
void od_Cond_Signal(od_Cond* cond);
void od_Cond_Broadcast(od_Cond* cond);

// Runs fn once per process, whichever thread comes first; the others wait until it has returned.
void od_RunOnce(od_Once* once, void (*fn)(void));

// fork(): prepare runs in the forking thread before it, child in the child after it (pthread_atfork). Nothing on
// Windows, which has no fork.
void od_Platform_AtFork(void (*prepare)(void), void (*child)(void));
// Shuts down the calling thread's OpenMP team (omp_pause_resource_all, OpenMP 5.0) when an OpenMP runtime is
// loaded (ELF weak symbol); nothing elsewhere, where no OpenMP runtime is linked.
void od_Platform_PauseOpenMP(void);

// A hint to the processor inside a spin-wait loop (x86 pause, arm64 yield), inline: it runs in the pool's spin.
static inline void od_Platform_Pause(void)
{
#if defined(__x86_64__) || defined(__i386__)
	__builtin_ia32_pause();
#elif defined(__aarch64__) && (defined(__GNUC__) || defined(__clang__))
	__asm__ volatile("yield");
#endif
}
