// The platform shim (platform.h): POSIX threads on Linux and macOS, Win32 on Windows. Design: the thin wrappers
// keep each system's own semantics (a Win32 SRW lock and condition variable behave as a pthread mutex and
// condition for the pool's use: no recursion, spurious wakeups allowed), so the pool above runs the same code on
// every platform. On Linux the calls are exactly those the pool made before (the same bits, the same threads).
#include "platform.h"

#include "clock.h"

#include <stdlib.h>

#ifdef OD_X86_AVX2
#include <cpuid.h>
#endif

#if defined(_WIN32)
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#elif defined(__APPLE__)
#include <sys/sysctl.h>
#include <time.h>
#else
#include <fcntl.h>
#include <stdlib.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>
#endif

#ifdef _WIN32

int od_Platform_Cpus(void)
{
	DWORD_PTR process, system;
	if (GetProcessAffinityMask(GetCurrentProcess(), &process, &system) && process != 0)
	{
		int count = 0;
		for (; process; process &= process - 1)
		{
			++count;
		}
		return count;
	}
	return (int)GetActiveProcessorCount(ALL_PROCESSOR_GROUPS);
}

int od_Platform_RunningThreads(void)
{
	return -1;
}

static DWORD WINAPI od_Thread_Main(LPVOID arg)
{
	od_Thread* thread = arg;
	thread->fn(thread->arg);
	return 0;
}

bool od_Thread_Start(od_Thread* thread, void* (*fn)(void*), void* arg)
{
	thread->fn = fn;
	thread->arg = arg;
	thread->handle = CreateThread(NULL, 0, od_Thread_Main, thread, 0, NULL);
	return thread->handle != NULL;
}

void od_Thread_Join(od_Thread* thread)
{
	WaitForSingleObject(thread->handle, INFINITE);
	CloseHandle(thread->handle);
}

void od_Mutex_Init(od_Mutex* mutex)
{
	InitializeSRWLock((PSRWLOCK)&mutex->lock);
}

void od_Mutex_Destroy(od_Mutex* mutex)
{
	(void)mutex; // an SRW lock holds no resource
}

void od_Mutex_Lock(od_Mutex* mutex)
{
	AcquireSRWLockExclusive((PSRWLOCK)&mutex->lock);
}

void od_Mutex_Unlock(od_Mutex* mutex)
{
	ReleaseSRWLockExclusive((PSRWLOCK)&mutex->lock);
}

void od_Cond_Init(od_Cond* cond)
{
	InitializeConditionVariable((PCONDITION_VARIABLE)&cond->cond);
}

void od_Cond_Destroy(od_Cond* cond)
{
	(void)cond; // a condition variable holds no resource
}

void od_Cond_Wait(od_Cond* cond, od_Mutex* mutex)
{
	SleepConditionVariableSRW((PCONDITION_VARIABLE)&cond->cond, (PSRWLOCK)&mutex->lock, INFINITE, 0);
}

void od_Cond_Signal(od_Cond* cond)
{
	WakeConditionVariable((PCONDITION_VARIABLE)&cond->cond);
}

void od_Cond_Broadcast(od_Cond* cond)
{
	WakeAllConditionVariable((PCONDITION_VARIABLE)&cond->cond);
}

static BOOL CALLBACK od_Once_Main(PINIT_ONCE once, PVOID fn, PVOID* context)
{
	(void)once;
	(void)context;
	((void (*)(void))fn)();
	return TRUE;
}

void od_RunOnce(od_Once* once, void (*fn)(void))
{
	InitOnceExecuteOnce((PINIT_ONCE)&once->once, od_Once_Main, (PVOID)fn, NULL);
}

void od_Platform_AtFork(void (*prepare)(void), void (*child)(void))
{
	(void)prepare;
	(void)child;
}

void od_Platform_PauseOpenMP(void)
{
}

double od_Clock(void)
{
	LARGE_INTEGER count, frequency;
	QueryPerformanceCounter(&count);
	QueryPerformanceFrequency(&frequency);
	return (double)count.QuadPart / (double)frequency.QuadPart;
}

#else // POSIX: Linux, macOS

int od_Platform_Cpus(void)
{
#ifdef __APPLE__
	int count = 0;
	size_t size = sizeof count;
	return sysctlbyname("hw.activecpu", &count, &size, NULL, 0) == 0 ? count : 0;
#else
	cpu_set_t set;
	return sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : (int)sysconf(_SC_NPROCESSORS_ONLN);
#endif
}

int od_Platform_RunningThreads(void)
{
#ifdef __APPLE__
	return -1;
#else
	// "0.52 0.58 0.59 3/467 12345": the 4th field is runnable/existing threads (a few hundred bytes read)
	char text[128];
	int file = open("/proc/loadavg", O_RDONLY);
	ssize_t size = file >= 0 ? read(file, text, sizeof text - 1) : -1;
	if (file >= 0)
	{
		close(file);
	}
	int fields = 0, running = 0;
	for (ssize_t k = 0; k < size && fields < 3; ++k)
	{
		fields += text[k] == ' ';
		if (fields == 3)
		{
			running = (int)strtol(text + k + 1, NULL, 10);
		}
	}
	if (running <= 0)
	{
		return -1;
	}
	long online = sysconf(_SC_NPROCESSORS_ONLN);
	int cpus = od_Platform_Cpus();
	return online > cpus && cpus > 0 ? (int)((long)running * cpus / online) : running;
#endif
}

bool od_Thread_Start(od_Thread* thread, void* (*fn)(void*), void* arg)
{
	return pthread_create(thread, NULL, fn, arg) == 0;
}

void od_Thread_Join(od_Thread* thread)
{
	pthread_join(*thread, NULL);
}

void od_Mutex_Init(od_Mutex* mutex)
{
	pthread_mutex_init(mutex, NULL);
}

void od_Mutex_Destroy(od_Mutex* mutex)
{
	pthread_mutex_destroy(mutex);
}

void od_Mutex_Lock(od_Mutex* mutex)
{
	pthread_mutex_lock(mutex);
}

void od_Mutex_Unlock(od_Mutex* mutex)
{
	pthread_mutex_unlock(mutex);
}

void od_Cond_Init(od_Cond* cond)
{
	pthread_cond_init(cond, NULL);
}

void od_Cond_Destroy(od_Cond* cond)
{
	pthread_cond_destroy(cond);
}

void od_Cond_Wait(od_Cond* cond, od_Mutex* mutex)
{
	pthread_cond_wait(cond, mutex);
}

void od_Cond_Signal(od_Cond* cond)
{
	pthread_cond_signal(cond);
}

void od_Cond_Broadcast(od_Cond* cond)
{
	pthread_cond_broadcast(cond);
}

void od_RunOnce(od_Once* once, void (*fn)(void))
{
	pthread_once(once, fn);
}

void od_Platform_AtFork(void (*prepare)(void), void (*child)(void))
{
	pthread_atfork(prepare, NULL, child);
}

#ifdef __ELF__
// OpenMP 5.0's call (libgomp, brought in by a CHOLMOD built with OpenMP, as Debian's); weak: NULL when no
// OpenMP runtime is loaded.
extern int omp_pause_resource_all(int kind) __attribute__((weak));
#define OD_OMP_PAUSE_SOFT 1
#endif

void od_Platform_PauseOpenMP(void)
{
#ifdef __ELF__
	if (omp_pause_resource_all)
	{
		omp_pause_resource_all(OD_OMP_PAUSE_SOFT);
	}
#endif
}

double od_Clock(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

#endif

bool od_Platform_HasAvx2Fma(void)
{
#ifdef OD_X86_AVX2
	static int known = -1; // a benign race: every thread computes the same answer
	if (known < 0)
	{
		unsigned a, b, c, d;
		bool avx = false;
		// leaf 1: FMA (ecx 12), OSXSAVE (27), AVX (28); xgetbv: the OS saves xmm and ymm; leaf 7: AVX2 (ebx 5)
		if (__get_cpuid(1, &a, &b, &c, &d) && (c & (1u << 27)) && (c & (1u << 28)) && (c & (1u << 12)))
		{
			unsigned lo, hi;
			__asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
			avx = (lo & 6u) == 6u && __get_cpuid_count(7, 0, &a, &b, &c, &d) && (b & (1u << 5));
		}
		const char* off = getenv("OPDEFORM_NO_AVX2");
		known = avx && !(off && *off && *off != '0');
	}
	return known == 1;
#else
	return false;
#endif
}
