// A monotonic clock for the solvers' time counters.
#include "clock.h"

#include <time.h>

double od_Clock(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}
